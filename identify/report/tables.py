"""The report's tables as plain rows (no plotting): fit summary, thesis error per pressure,
parameters with intervals, data-quality flags and fit diagnostics.

The same rows feed the PDF pages and the ``mfid fit`` summary on the terminal.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from identify.fit.bounds import bound_kinds
from identify.fit.result import FitResult, MCMCSummary
from identify.fit.run import FitRun
from identify.fit.sources import KeySource
from identify.fit.summary import (
    SummaryRow,
    fmt,
    fmt_pct,
    key_coefficients,
    num,
    tir_keys,
)

__all__ = [
    "FLAG_FIELDS",
    "ParamRow",
    "SummaryRow",
    "chunks",
    "data_flags",
    "error_rows",
    "fit_diagnostics",
    "fmt",
    "fmt_pct",
    "key_coefficients",
    "label",
    "mcmc_shortfall",
    "mcmc_warnings",
    "num",
    "parameter_rows",
    "summary_rows",
    "tir_keys",
]

def label(fit: FitResult) -> str:
    """``relation [form]``."""
    return f"{fit.relation} [{fit.form}]"


def summary_rows(run: FitRun) -> list[SummaryRow]:
    """One row per fit of the run, in fit order."""
    return run.summary_rows()


# ----- thesis error table ----------------------------------------------------------------------

def error_rows(fit: FitResult) -> list[tuple[str, str]]:
    """The thesis error table as the thesis lays it out: total first, then one row per
    pressure (ascending). Values in %."""
    by_p = fit.error_by_pressure_pct
    rows = [("total (mean)", fmt_pct(fit.error_total_pct))]
    for p in sorted(by_p):
        rows.append((f"{p:g} bar", fmt_pct(by_p[p])))
    return rows


# ----- parameter table -------------------------------------------------------------------------

@dataclass(frozen=True)
class ParamRow:
    """One free parameter: least-squares value and standard error, a 95 % interval, bounds
    (-inf/inf when open)."""

    name: str
    value: float
    stderr: float
    lo95: float
    hi95: float
    interval: str            # "MCMC 2.5-97.5 %" or "LS +/-2.04 s.e." (t at the dof)
    lower: float
    upper: float
    at_bound: bool
    in_tir: bool
    median: float = math.nan  # MCMC posterior median (NaN without MCMC)
    unidentified: str = ""    # why it is not identifiable on its own ("" when it is)
    bound_kind: str = ""      # at_bound: "physical" or "arbitrary" (identify.fit.bounds)


_COVARIANCE = {"sweep-jackknife": " (sweep jackknife)",
               "staged-sweep-jackknife": " (staged sweep jackknife)"}
"""How the label of a least-squares interval names a covariance other than iid
(docs/intervals.md)."""


def parameter_rows(fit: FitResult, key_sources: Mapping[str, KeySource] | None = None
                   ) -> list[ParamRow]:
    """The free parameters with value, standard error, 95 % interval, bounds and flags.

    The interval is the MCMC 2.5-97.5 % posterior quantiles when the fit has an MCMC
    summary for the parameter, else the profile interval where the fit has one, else value
    +/- t(0.975, dof) standard errors (FitResult.interval; labelled "LS profile" or with the
    quantile, and with the covariance when it is not iid); ``unidentified`` says why a
    coefficient is not identifiable on its own (FitResult.unidentified).
    """
    mc = fit.mcmc
    q025, q975, med = (mc.q025, mc.q975, mc.median) if mc is not None else ({}, {}, {})
    keys = set(tir_keys(fit, key_sources or {}))
    rows = []
    for name, value in fit.fitted.items():
        v, se = num(value), num(fit.stderr.get(name))
        if name in q025 and name in q975:
            lo, hi, how = num(q025[name]), num(q975[name]), "MCMC 2.5-97.5 %"
        else:
            lo, hi = fit.interval(name)
            how = ("LS profile" if name in fit.profile
                   else f"LS +/-{fit.quantile(name):.3g} s.e.")
            how += _COVARIANCE.get(fit.covariance, "")
        lower, upper = fit.bounds.get(name, (-math.inf, math.inf))
        kind = ""
        if name in fit.at_bound:
            side = 0 if abs(v - num(lower)) <= abs(v - num(upper)) else 1
            try:
                kind = bound_kinds(name, v)[side]
            except KeyError:  # not a table key (a relation's own scale)
                kind = "arbitrary"
        rows.append(ParamRow(name, v, se, lo, hi, how, num(lower), num(upper),
                             name in fit.at_bound, name in keys, num(med.get(name)),
                             fit.unidentified.get(name, ""), kind))
    return rows


# ----- flags and diagnostics -------------------------------------------------------------------

FLAG_FIELDS = ("run", "test", "flag", "detail")


def _walk_flags(obj: Any, out: list[dict]) -> None:
    """Every dict found in a list under a key named "flags" (any depth)."""
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            if k == "flags" and isinstance(v, list):
                for f in v:
                    if isinstance(f, Mapping):
                        out.append(dict(f))
                    elif isinstance(f, str):
                        out.append({"run": obj.get("run") or obj.get("id") or "",
                                    "test": obj.get("test") or "", "flag": f, "detail": ""})
            else:
                _walk_flags(v, out)
    elif isinstance(obj, list):
        for v in obj:
            _walk_flags(v, out)


def data_flags(run: FitRun, extraction: Any = None) -> list[dict[str, str]]:
    """Every data-quality flag from fit.json and extraction.json, each once, as
    {run, test, flag, detail} strings."""
    found: list[dict] = [dict(f) for f in run.flags if isinstance(f, Mapping)]
    if extraction is not None:
        _walk_flags(extraction, found)
    rows = []
    for f in found:
        row = {k: "" if f.get(k) is None else str(f.get(k)) for k in FLAG_FIELDS}
        extra = {k: v for k, v in f.items() if k not in FLAG_FIELDS}
        if extra and not row["detail"]:
            row["detail"] = ", ".join(f"{k}={v}" for k, v in extra.items())
        rows.append(row)
    # a run's list of flag names repeats flags listed with their detail elsewhere: keep one
    detailed = {(r["run"], r["flag"]) for r in rows if r["detail"]}
    out, seen = [], set()
    for row in rows:
        key = tuple(row.values())
        if key in seen or (not row["detail"] and (row["run"], row["flag"]) in detailed):
            continue
        seen.add(key)
        out.append(row)
    return out


def fit_diagnostics(run: FitRun) -> list[str]:
    """Warnings about the fits themselves: failures, parameters on bounds, active
    constraints, a best value reached by one start only, MCMC chains too short or with an
    acceptance fraction outside 0.2-0.5."""
    out = [f"FAILED {f}" for f in run.failed]
    for fit in run.results:
        name = label(fit)
        tag = f"{fit.relation}[{fit.form}]"
        if not fit.converged and not any(f.startswith(tag) for f in run.failed):
            out.append(f"{name}: did not converge ({fit.message})")
        if fit.at_bound:
            kinds = {r.name: r.bound_kind for r in parameter_rows(fit)}
            out.append(f"{name}: on a bound: "
                       + ", ".join(f"{n} ({kinds.get(n) or 'arbitrary'})"
                                   for n in fit.at_bound))
        if fit.active_constraints:
            out.append(f"{name}: active constraint(s): {'; '.join(fit.active_constraints)}")
        n, best = fit.n_starts, fit.starts_at_best
        if n > 1 and best <= 1:
            out.append(f"{name}: only {best} of {n} starts reached the best value "
                       "(possible local minimum)")
        mc = fit.mcmc
        if mc is not None:
            short = mcmc_shortfall(mc)
            if short:
                out.append(f"{name}: {short}")
            acc = mc.acceptance
            if math.isfinite(acc) and not 0.2 <= acc <= 0.5:
                out.append(f"{name}: MCMC acceptance fraction {acc:.2f} outside 0.2-0.5")
    return out


def mcmc_shortfall(mc: MCMCSummary) -> str:
    """Why an MCMC summary is not converged (the step cap or the time budget stopped it), with
    what would let it converge; empty when the chain is longer than 50 autocorrelation
    times."""
    if mc.converged:
        return ""
    steps = mc.n_steps
    taus = [t for t in mc.tau.values() if math.isfinite(t)]
    budget = mc.stopped == "budget"
    text = ("MCMC chain stopped by the time budget (--mcmc-budget) shorter than 50 "
            "autocorrelation times" if budget
            else "MCMC chain shorter than 50 autocorrelation times")
    if steps and taus:
        tau = max(taus)
        # the next 1000-step multiple above 50 tau, with 10 % margin for tau still growing
        need = int(math.ceil(55.0 * tau / 1000.0) * 1000)
        if budget and mc.seconds > 0:
            secs = int(math.ceil(need * mc.seconds / steps / 60.0) * 60)
            more = max(secs - int(mc.seconds), 60)
            text += (f" ({steps} steps in {mc.seconds:.0f} s, largest tau {tau:.0f}: its "
                     f"intervals are provisional; about {need} steps, {secs} s of this chain, "
                     f"would let it reach 50 tau: raise --mcmc-budget, the whole run's, by "
                     f"about {more} s, and --mcmc-max-steps to {need} if it is lower)")
        else:
            text += (f" ({steps} steps, largest tau {tau:.0f}: its intervals are provisional; "
                     f"--mcmc-max-steps {need} would let it reach 50 tau)")
    elif budget:
        text += (f" ({steps} steps in {mc.seconds:.1f} s, too few for an autocorrelation "
                 "time: its intervals are not usable; give it a larger --mcmc-budget)")
    return text


def mcmc_warnings(run: FitRun) -> list[str]:
    """The fit_diagnostics lines about MCMC chains that stopped at the cap or the budget."""
    return [f"{label(fit)}: {short}" for fit in run.results
            if fit.mcmc is not None and (short := mcmc_shortfall(fit.mcmc))]


def chunks(rows: Iterable, size: int) -> list[list]:
    """Split rows into lists of at most ``size`` (one list, possibly empty, at least)."""
    rows = list(rows)
    return [rows[i:i + size] for i in range(0, len(rows), size)] or [[]]
