"""Re from free rolling: Re = Vx / Omega.

Over the rolling part of a run, the plank travel x and the wheel rotation angle theta grow
together: x = Re theta + const, so Re is the least-squares slope of x against theta (the ratio of
the mean speeds, without differentiating the encoders). Free-rolling runs are used; a cell
without them falls back to the 0-deg reference runs of the relaxation and camber tests (which
the Flatplank description also names as free rolling).
"""
from __future__ import annotations

import math

import numpy as np

from identify.extract.diagnostics import Part, RunDiagnostic
from identify.extract.flags import Thresholds, cell_means, condition_flags
from identify.extract.linear import line_fit
from identify.extract.runs import RunData

__all__ = ["rolling_radius", "extract_rolling"]


def rolling_radius(x: np.ndarray, theta: np.ndarray, t: np.ndarray) -> dict:
    """Effective rolling radius of one run.

    Parameters
    ----------
    x : numpy.ndarray
        Plank travel [m].
    theta : numpy.ndarray
        Wheel rotation angle [rad].
    t : numpy.ndarray
        Time [s].

    Returns
    -------
    dict
        ``fit`` (:class:`LineFit` of x on theta over the rolling samples, slope = Re [m]) or
        None when the wheel did not turn, and ``speed`` (mean plank speed [m/s]).
    """
    moving = np.flatnonzero(np.diff(x) != 0)
    if moving.size < 3 or np.ptp(theta[moving[0]:]) <= 0:
        return {"fit": None, "speed": math.nan}
    a, b = int(moving[0]), int(moving[-1]) + 2
    fit = line_fit(theta, x, a, b)
    speed = abs(float(x[b - 1] - x[a])) / float(t[b - 1] - t[a])
    return {"fit": fit, "speed": speed}


def extract_rolling(free: list[RunData], references: list[RunData], th: Thresholds) -> Part:
    """Re per pressure x load cell: the mean over the runs of the cell.

    Parameters
    ----------
    free : list of RunData
        Free-rolling runs.
    references : list of RunData
        0-deg reference runs of other rolling tests (used only for cells without free
        rolling).
    th : Thresholds
        Flag thresholds.
    """
    diags, flags = [], []
    have = {r.cell for r in free}
    cells: dict[tuple[float, float], list[tuple[float, float]]] = {}
    for run in free + [r for r in references if r.cell not in have]:
        res = rolling_radius(run.ch["plank_x"], run.ch["wheel_angle"], run.ch["t"])
        fit = res["fit"]
        mine = condition_flags(run, th) if run.test == "free_rolling" else []
        flags += mine
        re = abs(fit.slope) if fit is not None else math.nan
        if fit is not None:
            cells.setdefault(run.cell, []).append((re, fit.slope_se))
        diags.append(RunDiagnostic(
            run.run, run.test, "Re", run.p_bar, run.load_N, run.start, re,
            None if fit is None else (fit.lo, fit.hi), "rad", 0 if fit is None else fit.n,
            math.nan if fit is None else fit.r2, math.nan if fit is None else fit.rmse,
            tuple(f.flag for f in mine), {"speed_mps": res["speed"]}))
    rows, spread = cell_means("free_rolling", "Re", cells, th)
    return Part(tuple(rows), tuple(diags), tuple(flags + spread))
