"""Assembling the written .tir of ``mfid fit``: which fit supplies each key, and why.

:func:`fit_folder` fits; this module decides what the .tir says and records where each value
came from (:class:`identify.fit.sources.KeySource`):

- the tyre's nominal conditions, unloaded radius and dimensions from ``tyre.toml`` (WIDTH,
  ASPECT_RATIO, RIM_RADIUS from its ``size`` string, :func:`identify.core.tyre_size`);
- every relation fitted in each of its forms, with ``--hold`` coefficients held at their
  default and, when the data cannot identify a coefficient, a re-fit with it held
  (:func:`fit_entry`; the status says so);
- for a relation with a nested pair of forms the form chosen by the data
  (:func:`identify.fit.relations.forms.choose_form`) or by ``--form``, whose keys (and implied
  constants, CMZ_FORM ...) go into the .tir (:func:`write_relation`);
- the validity limits from the measured ranges of the points that fitted the force model: the
  MF stages' when there are any, else every relation's (:func:`apply_limits`);
- every other key: its default, marked as not identified by these data (:func:`complete`).
"""
from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import lmfit
import numpy as np
import pandas as pd

from identify.core.errors import InputError
from identify.core.tyre import TyreInfo
from identify.core.tyre_size import parse_tyre_size
from identify.fit.identifiability import POOR, assess, problems, suspects
from identify.fit.limits import LIMIT_COLUMNS, measured_limits
from identify.fit.optimize import fit
from identify.fit.relations.forms import NESTED_FORMS, FormChoice, choose_form
from identify.fit.relations.plan import PLAN, PlanEntry, forms_of
from identify.fit.relations.plan import entry as plan_entry
from identify.fit.result import FitResult
from identify.fit.solve.problem import FitProblem
from identify.fit.sources import (
    DEFAULT,
    FITTED,
    FORMAT,
    HELD,
    MEASURED,
    SETTING,
    TYRE_TOML,
    KeySource,
)
from identify.model.parameters import PARAMETERS, spec

__all__ = ["FORMAT_SECTIONS", "HOLD_TOLERANCE", "EntryFit", "apply_limits", "apply_tyre",
           "complete", "fit_entry", "form_overrides", "hold_names", "mf_sources",
           "relation_reach", "write_relation"]

FORMAT_SECTIONS = ("MDI_HEADER", "UNITS")
"""Sections whose keys describe the file, not the tyre."""
HOLD_TOLERANCE = (1.25, 0.2)
"""A re-fit with the unidentifiable coefficients held replaces the free fit when its total
thesis error is at most max(1.25 x, + 0.2 percentage points) the free fit's; otherwise the
free fit is kept (the data needed those coefficients, even if not one by one)."""


@dataclass(frozen=True)
class EntryFit:
    """One plan entry fitted: the problem solved, the result kept (holds applied) and the
    result of the free fit (for the form choice)."""

    entry: PlanEntry
    problem: FitProblem
    result: FitResult
    free_result: FitResult


# ----- settings ----------------------------------------------------------------------------------

def form_overrides(values: Sequence[str]) -> dict[str, str]:
    """``--form REL=FORM`` values (repeated or comma-separated) -> {relation: form}.

    Raises
    ------
    InputError
        Not ``REL=FORM``, a relation without a choice of form, or an unknown form.
    """
    out: dict[str, str] = {}
    for item in (x.strip() for v in values for x in v.split(",") if x.strip()):
        rel, sep, form = (s.strip() for s in item.partition("="))
        if not sep or not rel or not form:
            raise InputError(None, f"{item!r} is not RELATION=FORM (e.g. CFx=quadratic_load)",
                             key="--form")
        if rel not in NESTED_FORMS:
            raise InputError(None, f"{rel} has no choice of form; --form applies to "
                                   f"{', '.join(NESTED_FORMS)}", key="--form")
        if form not in NESTED_FORMS[rel]:
            raise InputError(None, f"unknown form {form!r} of {rel}: choose "
                                   f"{' or '.join(NESTED_FORMS[rel])}", key="--form")
        out[rel] = form
    return out


def hold_names(values: Sequence[str]) -> tuple[str, ...]:
    """``--hold NAME`` values (repeated or comma-separated), upper-cased and checked against
    the parameter table.

    Raises
    ------
    InputError
        A name that is no .tir parameter.
    """
    names = tuple(dict.fromkeys(x.strip().upper() for v in values for x in v.split(",")
                                if x.strip()))
    for n in names:
        try:
            spec(n)
        except KeyError:
            raise InputError(None, f"{n} is not a .tir parameter", key="--hold") from None
    return names


# ----- tyre.toml ----------------------------------------------------------------------------------

def apply_tyre(tir: dict, tyre: TyreInfo) -> dict[str, KeySource]:
    """Put the nominal conditions, unloaded radius and dimensions of ``tyre`` into ``tir``;
    return their sources. A ``size`` that cannot be parsed is a warning (dimensions keep
    their defaults)."""
    src = {k: KeySource(TYRE_TOML, "nominal_load_N") for k in ("FNOMIN",)}
    src.update({k: KeySource(TYRE_TOML, "nominal_pressure_Pa") for k in ("NOMPRES", "INFLPRES")})
    size = parse_tyre_size(tyre.size) if tyre.size else None
    if tyre.size and size is None:
        warnings.warn(f"tyre.toml: size {tyre.size!r} is not a size designation "
                      "(e.g. 225/50 R17 or 20.5x7.0-13); WIDTH, ASPECT_RATIO, RIM_RADIUS keep "
                      "their defaults", UserWarning, stacklevel=2)
    if size is not None:
        for key, value in size.tir_values().items():
            tir[key] = value
            src[key] = KeySource(TYRE_TOML, f"size {size.text}")
    if math.isfinite(tyre.unloaded_radius_m) and tyre.unloaded_radius_m > 0:
        tir["UNLOADED_RADIUS"] = float(tyre.unloaded_radius_m)
        src["UNLOADED_RADIUS"] = KeySource(TYRE_TOML, "unloaded_radius_m")
    elif size is not None:
        tir["UNLOADED_RADIUS"] = size.unloaded_radius_m
        src["UNLOADED_RADIUS"] = KeySource(TYRE_TOML, f"size {size.text} (nominal)")
    return src


# ----- fitting one entry with holds --------------------------------------------------------------

def _held_problem(problem: FitProblem, names: Mapping[str, str],
                  values: Mapping[str, float]) -> FitProblem:
    P = lmfit.Parameters()
    for name, par in problem.parameters.items():
        P.add(name, value=par.value, vary=par.vary, min=par.min, max=par.max)
        if name in names:
            v = float(values.get(name, par.value))
            P[name].set(value=min(max(v, par.min), par.max), vary=False)
    return dataclasses.replace(problem, parameters=P)


def _default_of(name: str, tir: Mapping[str, float]) -> float:
    if name in tir:
        return float(tir[name])
    try:
        return float(spec(name).default)
    except (KeyError, TypeError, ValueError):
        return math.nan


def fit_entry(entry: PlanEntry, chars: pd.DataFrame, ctx, *, seed: int = 0,
              hold: Sequence[str] = (), auto_hold: bool = True) -> EntryFit | None:
    """Fit one plan entry.

    ``hold`` names are held at their default (the base .tir's value) and the result is
    assessed (identify.fit.identifiability). When it is poorly identified, the most suspect
    coefficient is held and the entry re-fitted, one coefficient at a time until the fit is
    identified; the held fit is kept when its error stays within :data:`HOLD_TOLERANCE` of the
    free fit's (otherwise the free fit is kept). Its status stays "poorly identified" and says
    what was held and why: ``--hold`` those coefficients to accept the held fit as identified.
    None when the entry's data are absent.
    """
    problem = entry.build(chars, ctx)
    if problem is None:
        return None
    free = {n for n, p in problem.parameters.items() if p.vary}
    user = {n: "held by --hold" for n in hold if n in free}
    defaults = {n: _default_of(n, ctx.tir) for n in problem.parameters}
    if user:
        problem = _held_problem(problem, user, defaults)
    result = assess(fit(problem, seed=seed), held=user)
    free_result = result
    if not auto_hold or result.identification != POOR or not result.converged:
        return EntryFit(entry, problem, result, free_result)
    limit = max(HOLD_TOLERANCE[0] * result.error_total_pct,
                result.error_total_pct + HOLD_TOLERANCE[1])
    held: dict[str, str] = {}
    trial, trial_problem = result, problem
    while trial.identification == POOR and len(trial.free) > 1:
        names = suspects(trial)
        if not names:
            break
        held[names[0]] = "not identifiable by these data (the free fit's problems above)"
        trial_problem = _held_problem(problem, held, defaults)
        trial = assess(fit(trial_problem, seed=seed))
        if not trial.converged or trial.error_total_pct > limit:
            note = (f"holding {', '.join(held)} raised the total error to "
                    f"{trial.error_total_pct:.3g} % from {result.error_total_pct:.3g} %: "
                    "kept free")
            return EntryFit(entry, problem, assess(result, notes=(note,)), free_result)
    if not held:
        return EntryFit(entry, problem, result, free_result)
    note = (f"re-fitted with {', '.join(held)} held: total error "
            f"{trial.error_total_pct:.3g} % against {result.error_total_pct:.3g} % free"
            + ("" if trial.identification == "ok" else "; still: " + "; ".join(
                problems(trial))))
    kept = assess(trial, held={**user, **held}, notes=(*problems(result), note))
    return EntryFit(entry, trial_problem, kept, free_result)


# ----- forms and keys ----------------------------------------------------------------------------

def write_relation(relation: str, fits: Mapping[str, EntryFit], chars: pd.DataFrame, ctx,
                   tir: dict, sources: dict[str, KeySource], *,
                   override: str | None = None) -> FormChoice | None:
    """Choose the form of ``relation`` that the .tir takes and write its keys.

    ``fits`` maps form -> EntryFit of every fitted form. A nested pair is decided by
    :func:`choose_form` (on the free fits; ``override`` from ``--form``); otherwise every
    form with ``writes`` writes its keys (the sidewall's one form per mode). A key an MF stage
    identified from trailer data is kept (the trailer measures the tyre the .tir describes at
    speed). Returns the FormChoice, or None without a choice of form.
    """
    choice = None
    if relation in NESTED_FORMS and any(f in fits for f in NESTED_FORMS[relation]):
        builders = {f: plan_entry(relation, f).build for f in forms_of(relation)}
        quantity = plan_entry(relation, NESTED_FORMS[relation][0]).quantity
        choice = choose_form(relation, {f: ef.free_result for f, ef in fits.items()},
                             builders, chars, ctx, quantity, override=override)
        chosen = [choice.form] if choice is not None and choice.form in fits else []
    else:
        chosen = [f for f, ef in fits.items() if ef.entry.writes]
    for form in chosen:
        _write_keys(relation, form, fits[form], tir, sources)
    return choice


def _write_keys(relation: str, form: str, ef: EntryFit, tir: dict,
                sources: dict[str, KeySource]) -> None:
    r = ef.result
    detail = f"{relation}/{form}"
    for key in ef.entry.writes:
        if key in sources and sources[key].kind == FITTED and \
                sources[key].detail.startswith("MF/"):
            continue
        if key not in r.parameters:
            continue
        tir[key] = float(r.parameters[key])
        if key in r.free:
            sources[key] = KeySource.fitted(detail, r.stderr.get(key, math.nan))
        elif key in r.held:
            sources[key] = KeySource(HELD, f"{detail}: {r.held[key]}")
        else:
            sources[key] = KeySource(FITTED, f"{detail} (held at this value by the form)")
    for key, value in ef.entry.constants.items():
        tir[key] = float(value)
        sources[key] = KeySource(FITTED, f"{detail} (the form's constant)")


def mf_sources(results: Sequence[FitResult], held: Mapping[str, Mapping[str, str]]
               ) -> dict[str, KeySource]:
    """Sources of the MF stages' keys: fitted (with standard error) or held (why). A fitted
    key whose value rests on held ones (FitResult.conditional) says so in its .tir comment:
    ``fitted MF/vertical (trailer; rests on Q_V2 = 0, held) +/- 284``."""
    out: dict[str, KeySource] = {}
    for stage, names in held.items():
        for n, why in names.items():
            out[n] = KeySource(DEFAULT, f"held in MF/{stage}: {why}")
    for r in results:
        for k in r.free:
            rests = r.conditional.get(k, "").split(" (", 1)[0]
            out[k] = KeySource.fitted(f"MF/{r.form} (trailer{'; ' + rests if rests else ''})",
                                      r.stderr.get(k, math.nan))
    return out


# ----- limits and the rest -----------------------------------------------------------------------

def relation_reach(chars: pd.DataFrame, ctx, wanted: Callable[[str], bool]) -> dict[str, float]:
    """The validity limits [SI] the characteristics' fits will add to the written .tir.

    ``measured_limits`` of the points of every plan entry of a ``wanted`` relation that builds
    a problem on ``chars`` (the rows measured_vs_model.csv will hold for them): what the MF
    stages' validity grid must cover besides the trailer data (identify.fit.mf.stages.fit_mf
    ``reach``), so that :func:`apply_limits` states no range the conditions were not held
    over. ``ctx``: the relations' Context.
    """
    columns = ("Fz_N", "gamma_deg", "alpha_rad", "kappa")
    frames = []
    for e in PLAN:
        problem = e.build(chars, ctx) if wanted(e.relation) else None
        if problem is None:
            continue
        n = problem.measured.size
        extra = problem.extra or {}
        frames.append(pd.DataFrame({"pi_bar": np.broadcast_to(problem.pressure_bar, n),
                                    **{c: np.asarray(extra.get(c, np.full(n, np.nan)), float)
                                       for c in columns}}))
    return measured_limits(pd.concat(frames, ignore_index=True)) if frames else {}


def apply_limits(tir: dict, sources: dict[str, KeySource], points: pd.DataFrame) -> None:
    """Set the validity limits to the ranges of the fitted points (measured_vs_model rows)
    that fitted the force model.

    FZMIN ... CAMMAX bound where a user of the .tir may evaluate the Magic Formula; when MF
    stages were fitted, their points are the range its coefficients were identified over (the
    relations' Flatplank points, at other loads and cambers, say nothing about the slip
    curves there). Without MF stages the relations' points are all the file was fitted on.
    """
    if "relation" in points and (points["relation"].astype(str) == "MF").any():
        points = points[points["relation"].astype(str) == "MF"]
        basis = "of the MF stages' fitted data"
    else:
        basis = "of the fitted data"
    limits = measured_limits(points)
    for (lo, hi), (column, _) in LIMIT_COLUMNS.items():
        if lo not in limits:
            continue
        used = points[column].notna() if column in points else pd.Series(False, points.index)
        quantities = sorted(set(points.loc[used, "quantity"].astype(str))) \
            if "quantity" in points else []
        what = ", ".join(quantities[:6]) + (" ..." if len(quantities) > 6 else "")
        for key in (lo, hi):
            tir[key] = limits[key]
            sources[key] = KeySource(MEASURED, f"{basis} ({what})")


def complete(sources: Mapping[str, KeySource], fittyp: int) -> dict[str, KeySource]:
    """Sources of every table key: the given ones, file-format keys, FITTYP (a setting), and
    the rest default (not identified by these data)."""
    out = dict(sources)
    for p in PARAMETERS:
        if p.name in out:
            continue
        if p.name == "FITTYP":
            out[p.name] = KeySource(SETTING, f"--fittyp {fittyp}")
        elif p.section in FORMAT_SECTIONS:
            out[p.name] = KeySource(FORMAT)
        elif p.section == "SCALING_COEFFICIENTS":
            out[p.name] = KeySource(DEFAULT, "neutral scaling factor")
        else:
            out[p.name] = KeySource.default()
    return out


def relations_in_plan_order() -> tuple[str, ...]:
    """The relation names of the plan, in order."""
    return tuple(dict.fromkeys(e.relation for e in PLAN))
