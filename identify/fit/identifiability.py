"""Is a fit's every free coefficient determined by the data? The status a fit reports.

A fit can converge and still leave coefficients the data do not determine: its value is then
an accident of the start, the bounds or the noise, and a .tir that carries it misleads. A
converged fit is **poorly identified** when any of these holds (thresholds below):

- a free coefficient sits on a bound (the optimum is where the bound put it);
- the 95 % interval of a coefficient (FitResult.interval: value +/- t(0.975, dof) standard
  errors) is wider than its bounds,
  or it has no finite standard error (the covariance is singular in that direction), or a
  standard error of 0 (the prediction does not change with it at the optimum: a Jacobian
  column of 0, which the pseudo-inverse gives no variance, e.g. Mx's QSX6 run to 8e4, where
  atan((QSX6 Fz/Fz0)^2) is pi/2 at every point);
- two coefficients are correlated beyond :data:`MAX_CORRELATION` (only a combination of them
  is determined);
- another minimum of the objective as good as the reported one, within :data:`RIVAL_CHI2` on
  the intervals' scale (FitResult.rivals), lies outside a coefficient's interval (the data
  hold two values of it; the linearised interval describes one);
- its value rests on coefficients held at values the data did not choose (FitResult.conditional:
  held ones that took effect only after the fit, with which its standard error would grow
  beyond identify.fit.mf.conditional.VIF_LIMIT; its interval assumes them exact);
- fewer than :data:`MIN_POINTS_PER_COEFFICIENT` data points per free coefficient;
- the validity conditions cost the fit beyond doubt and beyond a few per cent: the optimum is
  a polished point whose objective exceeds the least-squares optimum it left
  (FitResult.unconstrained_wls) by more than :data:`CONDITIONS_CHI2` in chi^2 (that point's
  residual variance) and by more than :data:`CONDITIONS_RATIO` times. The data then ask for
  a model that the conditions forbid somewhere on the validity grid, and the coefficients
  are where the conditions, not the data, put them (on a raw-sample TTC session of the golden
  test tyre, seed 5, before the re-fit test counted on the larger model's variance: the Fy
  stage's least-squares optimum broke Gyk > 0 and its polish ended 15 times higher, 22 %
  off the data, with every coefficient's interval reported as merely wide).

Otherwise its status is "ok". :func:`suspects` ranks the coefficients the problems name, so
that a caller can hold the worst at its default and re-fit, one at a time.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from identify.fit.bounds import ARBITRARY, bound_kinds
from identify.fit.result import FitResult
from identify.fit.solve.covariance import residual_variance
from identify.fit.status import fit_status, quality_problems

__all__ = ["CONDITIONS_CHI2", "CONDITIONS_RATIO", "MAX_CORRELATION",
           "MIN_POINTS_PER_COEFFICIENT", "OK", "POOR", "assess", "problems", "suspects",
           "unidentified"]

MAX_CORRELATION = 0.99
"""|correlation| of two estimates above which only their combination is determined."""
MIN_POINTS_PER_COEFFICIENT = 2
"""Fewest data points per free coefficient for a fit to carry them."""
CONDITIONS_CHI2 = 25.0
"""Rise of chi^2 = r^T r / s^2 (s^2 the least-squares optimum's residual variance) from the
least-squares optimum to the polished one beyond which the validity conditions' cost is
beyond doubt (5 standard deviations of a one-parameter chi^2 difference, as
identify.fit.mf.search.CHI2_GAP)."""
CONDITIONS_RATIO = 1.1
"""Ratio of the polished objective to the least-squares one beyond which the conditions' cost
matters: the RMS weighted residual 5 % larger. On thousands of points with correlated
residuals a chi^2 rise of 25 alone can be a fraction of a per cent of the objective."""
OK = "ok"
POOR = "poorly identified"


def _relative_se(r: FitResult, name: str) -> float:
    se = float(r.stderr.get(name, math.nan))
    if not math.isfinite(se):
        return math.inf
    lo, hi = r.bounds.get(name, (-math.inf, math.inf))
    span = hi - lo if math.isfinite(lo) and math.isfinite(hi) else abs(r.parameters[name])
    return se / span if span > 0 else math.inf


def _pairs(r: FitResult) -> list[tuple[str, str, float]]:
    out = []
    for key, c in r.correlations.items():
        a, _, b = key.partition("|")
        if a in r.free and b in r.free and math.isfinite(c) and abs(c) > MAX_CORRELATION:
            out.append((a, b, float(c)))
    return out


def _wide(r: FitResult) -> list[tuple[str, str, str]]:
    """(name, short reason, the line of :func:`problems`) of free coefficients without a
    usable interval."""
    out = []
    for n in r.free:
        se = float(r.stderr.get(n, math.nan))
        lo, hi = r.bounds.get(n, (-math.inf, math.inf))
        if not math.isfinite(se):
            out.append((n, "no finite standard error", f"{n} has no finite standard error"))
        elif se <= 0:  # its Jacobian column is 0: the pseudo-inverse gives it no variance
            out.append((n, "no effect on the data at the optimum",
                        f"{n} = {r.parameters[n]:.4g} has no effect on the data at the optimum "
                        "(standard error 0)"))
        elif math.isfinite(lo) and math.isfinite(hi):
            # FitResult.interval: the profile interval where there is one; a profile flat
            # from bound to bound spans them exactly, hence >=
            a, b = r.interval(n)
            if b - a >= hi - lo:
                out.append((n, "95 % interval wider than its bounds",
                            f"{n} = {r.parameters[n]:.4g}: 95 % interval [{a:.3g}, "
                            f"{b:.3g}] is wider than its bounds [{lo:g}, {hi:g}]"))
    return out


RIVAL_CHI2 = 3.84
"""A rival minimum (FitResult.rivals) within this chi^2 of the optimum, on the reported
intervals' scale, lies inside the 95 % region of one coefficient; identify.fit.mf.minima.rivals
keeps the minima within it."""


def _rivaled(r: FitResult) -> list[tuple[str, str, str]]:
    """(name, short reason, the line of :func:`problems`) of free coefficients that another
    minimum as good as the reported one puts outside their interval (FitResult.rivals)."""
    out = []
    for rival in r.rivals:
        if not rival.dchi2 <= RIVAL_CHI2:
            continue
        for n, v in rival.values.items():
            if n not in r.free:
                continue
            lo, hi = r.interval(n)
            if lo <= v <= hi:
                continue
            why = (f"another minimum within the 95 % region at {n} = {v:.4g} "
                   f"(chi^2 {rival.dchi2:+.2f} on the intervals' scale)")
            out.append((n, why, f"{n} = {r.parameters[n]:.4g}: {why}"))
    return out


def _conditional(r: FitResult) -> list[tuple[str, str, str]]:
    """(name, short reason, the line of :func:`problems`) of free coefficients whose value
    rests on held ones (FitResult.conditional)."""
    return [(n, why, f"{n} = {r.parameters[n]:.4g}: {why}; its interval assumes them exact")
            for n, why in r.conditional.items() if n in r.free]


def _bound_side(r: FitResult, name: str) -> tuple[str, float]:
    """("lower" or "upper", that bound) of the bound the estimate of ``name`` is at."""
    lo, hi = r.bounds.get(name, (-math.inf, math.inf))
    v = r.parameters[name]
    return ("lower", lo) if abs(v - lo) <= abs(v - hi) else ("upper", hi)


def _kind(r: FitResult, name: str) -> str:
    """"physical" or "arbitrary": the kind of the bound the estimate of ``name`` is at
    (identify.fit.bounds; a name the parameter table does not know: arbitrary)."""
    side = _bound_side(r, name)[0]
    try:
        kinds = bound_kinds(name, r.parameters[name])
    except KeyError:
        return ARBITRARY
    return kinds[0 if side == "lower" else 1]


def problems(r: FitResult) -> list[str]:
    """Why ``r`` is poorly identified, one line each (empty: identified)."""
    out = []
    n_free = len(r.free)
    if n_free and r.n_points < MIN_POINTS_PER_COEFFICIENT * n_free:
        out.append(f"{n_free} free coefficients on {r.n_points} points (fewer than "
                   f"{MIN_POINTS_PER_COEFFICIENT} points per coefficient)")
    for n in r.at_bound:
        side, bound = _bound_side(r, n)
        out.append(f"{n} = {r.parameters[n]:.4g} is at its {side} bound {bound:g} "
                   f"({_kind(r, n)})")
    out += [why for _, _, why in _wide(r)]
    out += [why for _, _, why in _rivaled(r)]
    out += [why for _, _, why in _conditional(r)]
    for a, b, c in _pairs(r):
        out.append(f"{a} and {b} are correlated {c:+.4f}: only their combination is "
                   "determined")
    cost = _conditions_cost(r)
    if cost is not None:
        ratio, rise = cost
        named = ", ".join(r.active_constraints) or "the validity conditions"
        out.append(f"the validity conditions ({named}) hold only at {ratio:.3g} times the "
                   f"objective of the least-squares optimum (chi^2 +{rise:.3g}): the data ask "
                   "for a model they forbid somewhere on the validity grid, and the "
                   "coefficients are where the conditions put them")
    return out


def _conditions_cost(r: FitResult) -> tuple[float, float] | None:
    """(objective ratio, chi^2 rise) of ``r``'s polished optimum over the least-squares
    optimum it left, when both exceed CONDITIONS_RATIO and CONDITIONS_CHI2; else None."""
    base = r.unconstrained_wls
    if not (math.isfinite(base) and base > 0 and math.isfinite(r.wls)):
        return None
    s2 = residual_variance(0.5 * base, r.n_points, len(r.free))
    ratio, rise = r.wls / base, (r.wls - base) / s2
    return (ratio, rise) if ratio > CONDITIONS_RATIO and rise > CONDITIONS_CHI2 else None


def unidentified(r: FitResult) -> dict[str, str]:
    """Free coefficients of ``r`` that are not identifiable on their own -> why (the first
    reason; the rules of :func:`problems` that name one coefficient): on a bound (its interval
    is one-sided and the estimate is the bound's), no finite standard error or a 95 % interval
    wider than its bounds (a near-null direction of J^T J), another minimum puts it outside
    its interval, its value rests on held coefficients, or correlated beyond
    :data:`MAX_CORRELATION` with another (only their combination is determined). Their
    intervals are not a statement about the coefficient; the others' are (docs/intervals.md)."""
    out: dict[str, str] = {}
    for n in r.at_bound:
        out.setdefault(n, f"at its {_kind(r, n)} {_bound_side(r, n)[0]} bound")
    for n, reason, _ in (*_wide(r), *_rivaled(r), *_conditional(r)):
        out.setdefault(n, reason)
    for a, b, c in _pairs(r):
        out.setdefault(a, f"correlated {c:+.4f} with {b}")
        out.setdefault(b, f"correlated {c:+.4f} with {a}")
    return {n: out[n] for n in r.free if n in out}


def suspects(r: FitResult) -> list[str]:
    """The free coefficients the problems name, most suspect first: by the number of problems
    that name them (on a bound, interval wider than its bounds, each correlated pair), ties by
    the larger standard error relative to the bounds (or value). Holding the first and
    re-fitting is the smallest step towards an identified fit."""
    count: dict[str, int] = {}
    for n in (*r.at_bound, *(n for n, _, _ in _wide(r)),
              *(x for a, b, _ in _pairs(r) for x in (a, b))):
        count[n] = count.get(n, 0) + 1
    return sorted((n for n in r.free if n in count),
                  key=lambda n: (-count[n], -_relative_se(r, n)))


def assess(r: FitResult, held: Mapping[str, str] | None = None,
           notes: tuple[str, ...] = ()) -> FitResult:
    """``r`` with its identification status and reasons (and the coefficients ``held``, name ->
    why, recorded), and its status (identify.fit.status): the error weighed against the noise
    floor first (a poor fit or a gross miss, whose reasons come first), then the
    identification. ``notes`` are further reasons (e.g. the problems of the free fit that led
    to the holds); any note, like any problem, makes the identification "poorly identified"."""
    held = dict(r.held) | dict(held or {})
    found = problems(r) if r.converged else []
    reasons = tuple(found) + tuple(notes)
    status = POOR if reasons else OK
    quality, why = (quality_problems(r.error_total_pct, r.error_by_pressure_pct,
                                     r.noise_floor_pct, r.floor_source)
                    if r.converged else (OK, []))
    # a re-assessment (a later step of the workflow) starts from the identification's reasons
    reasons = tuple(why) + tuple(x for x in reasons if x not in why)
    reasons += tuple(f"{n} held at {r.parameters.get(n, math.nan):.6g}: {why}"
                     for n, why in held.items())
    return dataclasses.replace(r, identification=status, reasons=reasons, held=held,
                               unidentified=unidentified(r) if r.converged else {},
                               fit_status=fit_status(r.converged, status, quality))
