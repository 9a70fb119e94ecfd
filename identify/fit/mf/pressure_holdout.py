"""Each measured pressure predicted by the MF model fitted without it (the report's pressure page).

The mission's claim is that the pressure terms carry: a model fitted at some pressures predicts
another. :func:`pressure_holdout` tests it on the session itself. For every pressure level of
the MF table (identify.fit.mf.stage_data.pressure_groups, the levels the objective weights), the MF
stages are fitted again on the table without that level's rows, and the held-out rows are
predicted; the page sets that error beside the in-sample one (the full fit on the same rows).

What the refit may and may not know of the held-out level (the cheapest honest way):

- each force and moment stage (Fx0 Fy0 Mz0 Fx Fy Mz Mx, in the fit's order, one pass) is
  solved again locally from the full fit's values, its free set the full fit's (a warm start:
  far cheaper than a new global search, and the basin of the coefficients of load, slip and
  camber is the one the remaining levels give too); the vertical and geometry stages (the
  radii, which do not enter these forces at a given slip, load and pressure) keep their values;
- every pressure coefficient (:data:`PRESSURE_COEFFICIENTS`) starts from its default, not from
  the full fit: what the pressure terms learnt from the held-out level must not survive. The
  identifiability screen runs again on the remaining rows, so with one level left the pressure
  terms stay at their defaults (the model cannot know a pressure effect it was never shown);
- the held-out rows are the full fit's own points at that level (after the segmentation and
  the bins of the full session), so the held-out and in-sample errors are on the same points.

The errors are the thesis metric of each stage at that level (100 RMS(model - measured) /
RMS(measured)); the stages of a force or moment (Fx0 Fy0 Mz0 Fx Fy Mz Mx) are shown.
"""
from __future__ import annotations

import math
import re
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from identify.core.progress import Progress
from identify.core.serial import Serial, from_data
from identify.fit.mf.problem import stage_problem
from identify.fit.mf.result import MFFit
from identify.fit.mf.search import MAX_NFEV
from identify.fit.mf.stage_data import pressure_groups
from identify.fit.mf.stage_specs import STAGES
from identify.fit.optimize import fit
from identify.fit.solve.engine import MF_SOLVE
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.parameters import defaults

__all__ = ["FORCE_STAGES", "PRESSURE_COEFFICIENTS", "PressureHoldout", "LevelHoldout",
           "pressure_holdout", "is_pressure_coefficient"]

FORCE_STAGES = ("Fx0", "Fy0", "Mz0", "Fx", "Fy", "Mz", "Mx")
"""The MF stages of a force or moment whose held-out error the page shows."""
PRESSURE_COEFFICIENTS = re.compile(r"^(PP[XYZ]\d+|PPMX\d+|PFZ1|QSY[78])$")
"""The MF coefficients of the inflation pressure (reset to their defaults in a held-out refit)."""


def is_pressure_coefficient(name: str) -> bool:
    """Whether ``name`` is an MF pressure coefficient (:data:`PRESSURE_COEFFICIENTS`)."""
    return bool(PRESSURE_COEFFICIENTS.match(name))


@dataclass(frozen=True)
class LevelHoldout(Serial):
    """One pressure level held out.

    Attributes
    ----------
    pressure_bar : float          the level [bar] (the MF table's pressure group)
    points : mapping              stage -> its points at this level
    insample_pct : mapping        stage -> thesis error of the full fit at this level [%]
    heldout_pct : mapping         stage -> thesis error of the refit without it [%]
    seconds : float               wall time of the refit [s]
    converged : bool              every stage of the refit converged
    """

    pressure_bar: float
    points: Mapping[str, int]
    insample_pct: Mapping[str, float]
    heldout_pct: Mapping[str, float]
    seconds: float
    converged: bool


@dataclass(frozen=True)
class PressureHoldout(Serial):
    """Every pressure level of the MF fit predicted without it (fit.json ``pressure_holdout``).

    Attributes
    ----------
    levels : tuple of LevelHoldout   one per pressure level, increasing (empty when skipped)
    skipped : str                    why there is none ("" when there are levels)
    method : str                     how the refits were made (for the page)
    seconds : float                  wall time of every refit [s]
    """

    levels: tuple[LevelHoldout, ...]
    skipped: str = ""
    method: str = ""
    seconds: float = 0.0

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> PressureHoldout | None:
        """Inverse of :meth:`to_dict`; None for fit.json's empty entry (not computed)."""
        return from_data(cls, d) if d else None


METHOD = ("each level's rows removed from the MF table; the force and moment stages solved "
          "again locally from the full fit's values (its free coefficients, one pass), every "
          "pressure coefficient restarted from its default and held where the rows left do "
          "not identify it; the held-out rows predicted")


def _num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _rms_pct(measured: np.ndarray, model: np.ndarray) -> float:
    ok = np.isfinite(measured) & np.isfinite(model)
    den = float(np.sum(measured[ok] ** 2))
    if not ok.any() or den == 0.0:
        return math.nan
    return 100.0 * math.sqrt(float(np.sum((model[ok] - measured[ok]) ** 2)) / den)


def stage_prediction(params: Mapping[str, float], stage: str, points: pd.DataFrame
                     ) -> np.ndarray:
    """The stage's quantity (Fx, Fy, Mz or Mx) of ``params`` at its points, as the fit
    evaluates it (useMode FIT_MODE)."""
    out = evaluate(params, points["Fz"].to_numpy(float), points["kappa"].to_numpy(float),
                   points["alpha"].to_numpy(float), points["gamma"].to_numpy(float),
                   points["Vx"].to_numpy(float), points["p"].to_numpy(float), mode=FIT_MODE)
    return np.asarray(out[STAGES[stage].quantity], dtype=float)


def nearest(values: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """Index of the level nearest to each value (-1 where the value is not finite)."""
    out = np.full(values.shape, -1, dtype=int)
    ok = np.isfinite(values)
    out[ok] = np.argmin(np.abs(values[ok, None] - levels[None, :]), axis=1)
    return out


def heldout_start(params: Mapping[str, float]) -> dict[str, float]:
    """The refit's start: ``params`` with every pressure coefficient at its default."""
    d = defaults()
    return {k: (float(d[k]) if is_pressure_coefficient(k) and k in d else float(v))
            for k, v in params.items()}


def refit_without(trailer: pd.DataFrame, mf: MFFit, rows_out: np.ndarray
                  ) -> tuple[dict[str, float], bool]:
    """The MF values refitted without the rows ``rows_out`` of ``trailer`` (see the module
    notes), and whether every stage's solve converged."""
    table = trailer[~rows_out].reset_index(drop=True)
    params = heldout_start(mf.params)
    converged = True
    with threadpool_limits(limits=1, user_api="blas"):  # small SVDs (as fit_mf)
        for r in mf.results:
            if r.form not in FORCE_STAGES:
                continue
            sp = stage_problem(r.form, table, params, free={r.form: list(r.free)},
                               screen=True)
            if sp is None or not sp.problem.free:
                continue
            x0 = sp.problem.x0()
            res = fit(sp.problem, starts=x0[None, :], max_nfev=MAX_NFEV, tol=MF_SOLVE)
            converged &= bool(res.converged)
            params.update({n: float(res.parameters[n]) for n in res.free})
    return params, converged


def _timed_refit(trailer: pd.DataFrame, mf: MFFit, rows_out: np.ndarray
                 ) -> tuple[dict[str, float], bool, float]:
    """:func:`refit_without` and its wall time [s] (a worker's job)."""
    t = time.perf_counter()
    params, converged = refit_without(trailer, mf, rows_out)
    return params, converged, time.perf_counter() - t


def pressure_holdout(trailer: pd.DataFrame, mf: MFFit, *,
                     progress: Progress | None = None,
                     pool: Executor | None = None) -> PressureHoldout:
    """Refit the MF stages of ``mf`` without each pressure level of ``trailer`` (the table
    ``mf`` was fitted to) and predict it (see the module notes).

    ``pool`` (worker processes, identify.core.workers.process_pool) takes every other level's
    refit while this process solves the rest: the refits do not depend on each other, and
    each is computed from its own arguments alone, so the numbers are those of the serial
    loop."""
    t0 = time.perf_counter()
    shown = [r.form for r in mf.results if r.form in FORCE_STAGES]
    groups = pressure_groups(trailer)
    levels = np.unique(groups[np.isfinite(groups)])
    if levels.size < 2:
        return PressureHoldout((), skipped=f"{levels.size} pressure level(s) in the fitted "
                                           "data: none to hold out", method=METHOD)
    if not shown:
        return PressureHoldout((), skipped="no force or moment stage was fitted", method=METHOD)
    away = {k: pool.submit(_timed_refit, trailer, mf, groups == level)
            for k, level in enumerate(levels) if pool is not None and k % 2 == 1}
    out = []
    for k, level in enumerate(levels):
        if progress is not None:
            progress(f"pressure hold-out: MF stages without {level:.2f} bar")
        params, converged, seconds = (away[k].result() if k in away
                                      else _timed_refit(trailer, mf, groups == level))
        points, ins, hout = {}, {}, {}
        for r in mf.results:
            if r.form not in shown:
                continue
            # a stage's own pressure groups are its points' (a few kPa off the table's)
            at = nearest(np.asarray(r.pressure_bar, float), levels) == k
            if not at.any():
                continue
            pts = mf.points[r.form][at]
            measured = np.asarray(r.measured, float)[at]
            points[r.form] = int(at.sum())
            ins[r.form] = _rms_pct(measured, np.asarray(r.predicted, float)[at])
            hout[r.form] = _rms_pct(measured, stage_prediction(params, r.form, pts))
        out.append(LevelHoldout(float(level), points, ins, hout, seconds, converged))
    return PressureHoldout(tuple(out), method=METHOD, seconds=time.perf_counter() - t0)


def summary_lines(ph: PressureHoldout | None) -> Sequence[str]:
    """One line per level: the in-sample and held-out error of each stage."""
    if ph is None:
        return []
    if not ph.levels:
        return [f"pressure hold-out: {ph.skipped}"] if ph.skipped else []
    lines = []
    for lv in ph.levels:
        parts = [f"{s} {lv.insample_pct[s]:.1f}->{lv.heldout_pct[s]:.1f}"
                 for s in lv.heldout_pct]
        lines.append(f"pressure hold-out {lv.pressure_bar:.2f} bar (in-sample -> held-out %): "
                     + ", ".join(parts))
    return lines
