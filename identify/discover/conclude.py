"""Problem summaries and the plain-words conclusion of a discovery run."""
from __future__ import annotations

import numpy as np

from identify.discover.drift import DRIFT_KEY
from identify.discover.prepared_problem import Working, cells, final_floor, total_error_pct
from identify.discover.result import Accepted, ProblemSummary
from identify.fit.result import FitResult
from identify.fit.solve.engine import covariance
from identify.fit.solve.metric import thesis_error_by_group

__all__ = ["summaries", "conclusion", "UNEXPLAINED_RATIO"]

UNEXPLAINED_RATIO = 1.25
"""A final error above this multiple of the noise floor is an unexplained discrepancy."""


def standard_errors(jac: np.ndarray, r: np.ndarray, free, clusters=None) -> dict[str, float]:
    """Standard errors of the coefficients ``free`` from the Jacobian ``jac`` (n, k) and the
    residuals ``r`` (n,) at the optimum: cluster-robust over ``clusters`` (index arrays, one
    per sweep) where the noise is correlated along the sweeps, as the confirming test's, else
    from the residual variance. An interval that ignored the correlation along a sweep would
    claim a precision the data do not hold."""
    if jac.shape[1] == 0:
        return {}
    cov = covariance(jac, r, clusters=clusters) if clusters is not None else covariance(jac, r)
    return {name: float(np.sqrt(max(cov[i, i], 0.0))) for i, name in enumerate(free)}


def _stderr(w: Working) -> dict[str, float]:
    return standard_errors(w.sol.jac, w.sol.r, w.problem.free,
                           w.objective.index if w.noise.kind == "cluster" else None)


def summaries(works: list[Working], reads: dict | None = None,
              upstream: dict | None = None) -> tuple[ProblemSummary, ...]:
    """One :class:`ProblemSummary` per working problem (final state); ``reads`` maps a
    problem's name to the keys it takes from other problems (key -> source problem),
    ``upstream`` to the problems whose coefficients it uses."""
    out = []
    for w in works:
        p = w.problem
        floor, source = final_floor(w)
        pred = p.predict(w.x)
        arrays = {"measured": p.measured, "pressure_bar": p.pressure_bar,
                  "base_predicted": w.base_predicted, "final_predicted": pred}
        for key in ("Fz_N", "gamma_deg", "alpha_rad", "kappa"):
            if key in p.extra:
                arrays[key] = np.asarray(p.extra[key], dtype=float)
        out.append(ProblemSummary(
            name=w.name, relation=p.relation, form=p.form, unit=p.unit,
            n_points=int(p.measured.size), free=w.base_free,
            candidates=tuple(c.name for c in w.candidates) + tuple(w.history),
            base_error_pct=w.base_error_pct,
            final_error_pct=total_error_pct(p, pred),
            base_error_by_pressure_pct=w.base_by_pressure, converged=w.converged,
            stationary=w.stationary, message=w.message, noise=w.noise,
            base_noise=w.base_noise or w.noise,
            noise_floor_pct=float(floor), floor_source=source,
            cells=cells(p, w.base_predicted), final_cells=cells(p, pred), fit_seconds=w.fit_seconds,
            score_seconds=w.score_seconds, parameters=p.values(w.x), stderr=_stderr(w),
            final_free=p.free, arrays=arrays, fit=_fit_result(w, pred),
            heldout_scheme=w.fold_scheme, reads=dict((reads or {}).get(w.name, {})),
            upstream=tuple((upstream or {}).get(w.name, ()))))
    return tuple(out)


def _fit_result(w: Working, pred: np.ndarray) -> FitResult:
    """The final fit as a :class:`~identify.fit.result.FitResult` (for fit.json)."""
    p = w.problem
    lo, hi = p.bounds()
    x = w.x
    by_p = thesis_error_by_group(pred, p.measured, p.pressure_bar)
    return FitResult(
        relation=p.relation, form=p.form, objective="wls", parameters=p.values(x), free=p.free,
        stderr=_stderr(w), bounds={n: (float(a), float(b)) for n, a, b in zip(p.free, lo, hi)},
        at_bound=tuple(n for n, v, a, b in zip(p.free, x, lo, hi) if v <= a or v >= b),
        active_constraints=(), error_total_pct=float(np.mean(list(by_p.values()))),
        error_by_pressure_pct=by_p, wls=w.sol.rss, n_points=int(p.measured.size),
        converged=bool(w.sol.ok), message=w.sol.message, n_starts=1, starts_at_best=1,
        correlations={}, predicted=pred, measured=p.measured, pressure_bar=p.pressure_bar,
        seconds=w.fit_seconds)


def _value(a: Accepted) -> str:
    parts = []
    for k, v in a.coefficients.items():
        se = a.stderr.get(k, float("nan"))
        parts.append(f"{k} = {v:.3g} +/- {se:.2g}" if np.isfinite(se) else f"{k} = {v:.3g}")
    return ", ".join(parts)


def _worst_cell(s: ProblemSummary) -> str:
    if not s.final_cells:
        return ""
    c = max(s.final_cells, key=lambda c: c["error_pct"] if np.isfinite(c["error_pct"]) else -1)
    where = [f"{c['pi_bar']:g} bar"]
    if c["Fz_N"] is not None:
        where.append(f"{c['Fz_N']:g} N")
    if c["gamma"] != "0":
        where.append(f"camber {c['gamma']}")
    return f"; largest in the cell {', '.join(where)} ({c['error_pct']:.2f} %)"


def conclusion(accepted: list[Accepted], probs: tuple[ProblemSummary, ...], steps,
               notes=()) -> str:
    """Plain words: what is missing (or that nothing is), errors against the noise floor, the
    held-out scheme, problems not analysed."""
    lines = []
    for a in accepted:
        floor = f" (noise floor {a.noise_floor_pct:.2g} %)" if np.isfinite(a.noise_floor_pct) \
            else ""
        scheme = f" ({a.heldout_scheme})" if a.heldout_scheme else ""
        err = (f"Error {a.error_before_pct:.2g} % -> {a.error_after_pct:.2g} %{floor}; "
               f"held out{scheme} {a.heldout_before_pct:.2g} % -> {a.heldout_after_pct:.2g} %.")
        if any(k == DRIFT_KEY for k in a.coefficients) and not a.ambiguous_with:
            lines.append(f"Drift absorbed, not a tyre property and not written to the .tir: "
                         f"{a.description} ({_value(a)}; {a.problem}). {err}")
        elif a.ambiguous_with:
            names = " / ".join((a.name,) + tuple(a.ambiguous_with))
            lines.append(f"Missing effect in {a.problem}, ambiguous: one of {names} (they "
                         f"cannot be told apart with this test matrix; {a.name} was added: "
                         f"{a.description}, {_value(a)}). {err}")
        else:
            note = f" Note: {a.note}." if a.note else ""
            lines.append(f"Missing effect: {a.description} ({_value(a)}; {a.problem}). "
                         f"{err}{note}")
    n_tested = len(steps[0].candidates) if steps else 0
    if not accepted:
        worst = max(probs, key=lambda p: p.final_error_pct - p.noise_floor_pct, default=None)
        tail = (f"; {worst.name}: error {worst.final_error_pct:.2g} %, noise floor "
                f"{worst.noise_floor_pct:.2g} % ({worst.floor_source})"
                if worst is not None else "")
        lines.append(f"No missing effect found ({n_tested} candidates tested on {len(probs)} "
                     f"problem(s){tail}).")
    for s in probs:
        if not s.converged or not s.stationary:
            lines.append(f"Warning: the base fit of {s.name} did not reach a minimum "
                         f"({s.message}); structure left there may be a fit failure.")
        if (s.floor_source.startswith("within") and np.isfinite(s.noise_floor_pct)
                and s.final_error_pct > UNEXPLAINED_RATIO * s.noise_floor_pct):
            lines.append(f"Unexplained discrepancy in {s.name}: error {s.final_error_pct:.2g} "
                         f"% vs noise floor {s.noise_floor_pct:.2g} %{_worst_cell(s)}.")
    untestable = sorted({f"{r.name} ({r.problem})" for r in (steps[0].candidates if steps
                                                               else ()) if not r.testable})
    if untestable:
        lines.append("Not testable with this test matrix: " + ", ".join(untestable) + ".")
    lines += [f"Note: {n}." for n in notes]
    return "\n".join(lines)
