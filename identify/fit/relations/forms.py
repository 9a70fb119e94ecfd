"""Which form of a relation the .tir takes: chosen by the data, with a stated criterion.

Several relations have a simpler and a richer form, the simpler nested in the richer one (the
richer reduces to it at a neutral value of its extra coefficients): CFx and CFy linear or
quadratic in load (PCFX2/PCFY2 = 0), the yaw stiffness T1 or T2, rolling resistance without or
with load and pressure exponents (QSY7 = 1, QSY8 = 0). Writing the richer form always would fit
noise and extrapolate badly; writing the simpler always (what mfid did) misses a real
curvature: on the bundled sample the linear CFx is off by up to 10 %.

Criterion (both must hold for the richer form):

1. **F test**, p < ALPHA = 0.01, on the residual sums of squares of both forms refitted by
   least squares with relative weights (1/|measured|: a characteristic is measured to a
   relative accuracy), each from its thesis-metric optimum. The thesis optimum itself is not a
   least-squares one (it minimises a mean of root sums), so its residuals would bias the test.
   For a nested pair whose simpler form is true this keeps the simpler form in 99 % of data
   sets (a one-sided bound on the extra coefficient, PCFX2 <= 0, makes it stricter: the
   estimate sits on the bound in about half the data sets); a hypothesis test is used rather
   than AIC/BIC because with 15 points AIC prefers a needless extra coefficient in ~16 % of data
   sets and BIC in ~10 %.
2. **Held-out error not larger**: the leave-one-pressure-out thesis error (each pressure
   predicted by the form refitted without it, starting from the full-data optimum) of the
   richer form is at most that of the simpler one. This guards against a term that fits one
   pressure's scatter. It needs three or more pressures, each with two or more loads; otherwise
   it is not applied and the choice says so.

A user can override the choice (``--form CFx=quadratic_load``); the choice records that.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from identify.core.serial import Serial
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from identify.fit.solve.problem import FitProblem

__all__ = ["ALPHA", "NESTED_FORMS", "FormChoice", "choose_form", "f_test",
           "held_out_error", "least_squares_fit"]

ALPHA = 0.01
"""Significance level of the F test for the richer form."""

NESTED_FORMS: dict[str, tuple[str, str]] = {
    "CFx": ("linear_load", "quadratic_load"),
    "CFy": ("linear_load", "quadratic_load"),
    "CMz": ("T1", "T2"),
    "RR": ("old", "new"),
}
"""Relation -> (simpler form, richer form it is nested in)."""

Builder = Callable[[pd.DataFrame, Any], FitProblem | None]


@dataclass(frozen=True)
class FormChoice(Serial):
    """The form of one relation written to the .tir, and why.

    Attributes
    ----------
    relation : str
    form : str                     the chosen form
    simpler, richer : str          the nested pair compared
    criterion : str                one line: the rule applied
    reason : str                   one line: what decided, with the numbers
    f_statistic, p_value : float   F test of the richer against the simpler form
    held_out_pct : Mapping[str, float]  leave-one-pressure-out thesis error per form [%]
                                   (empty when not applicable)
    overridden : bool              chosen by the user (``--form``), not by the criterion
    """

    relation: str
    form: str
    simpler: str
    richer: str
    criterion: str
    reason: str
    f_statistic: float = float("nan")
    p_value: float = float("nan")
    held_out_pct: Mapping[str, float] = field(default_factory=dict)
    overridden: bool = False



CRITERION = (f"richer form only if its F test against the simpler one has p < {ALPHA:g} and "
             "its leave-one-pressure-out error is not larger")


def least_squares_fit(build: Builder, chars: pd.DataFrame, ctx: Any,
                      result: FitResult) -> FitResult:
    """The form refitted by least squares with relative weights (sigma = |measured|), a local
    solve from ``result`` (its thesis-metric optimum)."""
    problem = build(chars, ctx)
    sigma = np.maximum(np.abs(problem.measured), np.finfo(float).tiny)
    problem = dataclasses.replace(problem, objective="wls", sigma=sigma)
    x0 = np.array([result.parameters[n] for n in problem.free], dtype=float)
    return fit(problem, starts=x0[None, :])


def f_test(simple: FitResult, rich: FitResult) -> tuple[float, float]:
    """(F, p) of the richer fit against the simpler one nested in it, from their residual sums
    of squares (FitResult.wls of least-squares fits, :func:`least_squares_fit`) and numbers of
    free coefficients."""
    df1 = len(rich.free) - len(simple.free)
    df2 = rich.n_points - len(rich.free)
    if df1 <= 0 or df2 <= 0 or not rich.wls > 0:
        return float("nan"), float("nan")
    f = max(simple.wls - rich.wls, 0.0) / df1 / (rich.wls / df2)
    return float(f), float(stats.f.sf(f, df1, df2))


def _pressure_design_ok(chars: pd.DataFrame, quantity: str) -> bool:
    d = chars[chars["quantity"] == quantity]
    if d.empty:
        return False
    loads = d.groupby(np.round(d["pi_bar"].to_numpy(float), 6))["Fz_N"].nunique()
    return len(loads) >= 3 and bool((loads >= 2).all())


def held_out_error(build: Builder, chars: pd.DataFrame, ctx: Any,
                   result: FitResult, quantity: str) -> float:
    """Leave-one-pressure-out thesis error [%] of one form: mean over the pressures of the
    error of that pressure's points predicted by the form refitted on the others (a local
    solve from the full-data optimum ``result``). NaN when a fold cannot be built."""
    d = chars[chars["quantity"] == quantity]
    levels = np.unique(np.round(d["pi_bar"].to_numpy(float), 6))
    errors = []
    for level in levels:
        out = np.isclose(chars["pi_bar"].to_numpy(float), level) & \
            (chars["quantity"] == quantity).to_numpy()
        train, test = build(chars[~out], ctx), build(chars[out], ctx)
        if train is None or test is None:
            return float("nan")
        x0 = np.array([result.parameters[n] for n in train.free], dtype=float)
        trained = fit(train, starts=x0[None, :])
        values = {**test.values(), **trained.parameters}
        with np.errstate(all="ignore"):
            pred = np.asarray(test.model(values), dtype=float)
        meas = test.measured
        errors.append(100.0 * np.sqrt(np.sum((pred - meas) ** 2) / np.sum(meas ** 2)))
    return float(np.mean(errors)) if errors else float("nan")


def choose_form(relation: str, results: Mapping[str, FitResult],
                builders: Mapping[str, Builder], chars: pd.DataFrame, ctx: Any,
                quantity: str, override: str | None = None) -> FormChoice | None:
    """Choose the form of ``relation`` the .tir takes (criterion in the module docstring).

    Parameters
    ----------
    relation : str
        A key of :data:`NESTED_FORMS`.
    results : mapping form -> FitResult
        The full-data fits of the forms (both of the nested pair must be there and converged
        for the criterion to apply; otherwise the one that converged is taken).
    builders : mapping form -> callable
        (characteristics, context) -> FitProblem, to refit on subsets (held-out check).
    chars : DataFrame
        The characteristics the fits used.
    ctx : object
        The context the builders take.
    quantity : str
        The characteristic the relation is fitted to (``"CFx"``, ``"FxRR"`` ...).
    override : str, optional
        A form named by the user; it is taken whatever the criterion says.

    Returns
    -------
    FormChoice or None
        None when the relation has no nested pair or neither form was fitted.
    """
    if relation not in NESTED_FORMS:
        return None
    simpler, richer = NESTED_FORMS[relation]
    s, r = results.get(simpler), results.get(richer)
    if s is None and r is None:
        return None
    base = dict(relation=relation, simpler=simpler, richer=richer, criterion=CRITERION)
    both = s is not None and r is not None and s.converged and r.converged
    f, p = (f_test(least_squares_fit(builders[simpler], chars, ctx, s),
                   least_squares_fit(builders[richer], chars, ctx, r))
            if both else (float("nan"), float("nan")))
    if override is not None:
        if override not in (simpler, richer):
            raise ValueError(f"unknown form {override!r} of {relation}: choose {simpler} or "
                             f"{richer}")
        return FormChoice(form=override, f_statistic=f, p_value=p, overridden=True,
                          reason=f"chosen by the user (--form {relation}={override}); "
                                 f"F = {f:.3g}, p = {p:.2g}", **base)
    if not both:
        ok = [name for name, x in ((simpler, s), (richer, r)) if x is not None and x.converged]
        form = ok[0] if ok else (simpler if s is not None else richer)
        return FormChoice(form=form, reason="the other form did not converge" if ok else
                          "neither form converged", **base)
    if not (p < ALPHA):
        return FormChoice(form=simpler, f_statistic=f, p_value=p,
                          reason=f"the {richer} form is not significantly better "
                                 f"(F = {f:.3g}, p = {p:.2g})", **base)
    if not _pressure_design_ok(chars, quantity):
        return FormChoice(form=richer, f_statistic=f, p_value=p,
                          reason=f"F = {f:.3g}, p = {p:.2g}; held-out check not applicable "
                                 "(fewer than 3 pressures with 2 loads each)", **base)
    held = {form: held_out_error(builders[form], chars, ctx, res, quantity)
            for form, res in ((simpler, s), (richer, r))}
    if np.isfinite(held[richer]) and np.isfinite(held[simpler]) and \
            held[richer] > held[simpler]:
        return FormChoice(form=simpler, f_statistic=f, p_value=p, held_out_pct=held,
                          reason=f"F = {f:.3g}, p = {p:.2g}, but the {richer} form predicts "
                                 f"left-out pressures worse ({held[richer]:.3g} % against "
                                 f"{held[simpler]:.3g} %)", **base)
    return FormChoice(form=richer, f_statistic=f, p_value=p, held_out_pct=held,
                      reason=f"F = {f:.3g}, p = {p:.2g}; left-out pressures "
                             f"{held[richer]:.3g} % against {held[simpler]:.3g} %", **base)
