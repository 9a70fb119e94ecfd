"""The test design of a problem: condition cells, whether pressure is crossed with the other
conditions, and the held-out folds that fit the design.

A held-out check is only fair when every fold's training points still cover the conditions the
model needs. Leaving one pressure level out tests a pressure law by interpolation and
extrapolation in pressure, which is right when pressure is varied independently of the other
conditions (every load at every pressure, as the thesis grid and the trailer matrices). When
load and pressure move together (a rolling-resistance table of five pressure/load pairs),
leaving a pressure out also leaves its load out, and a held-out rise then says nothing about
the pressure law. There the folds keep every condition cell (pressure x load x characteristic)
represented in training: k folds over whole sweeps (or points) within each cell.

Schemes (:func:`folds`):

- ``leave one pressure level out``: three or more pressure levels, crossed with the rest;
- ``leave one pressure level out of the conditions measured at several pressures``: three or
  more pressure levels, partly crossed (some loads at several pressures, others at one): each
  fold holds out one pressure level's points in the shared conditions; the conditions seen
  at one pressure only always train;
- ``k-fold over sweeps (or rows) within pressure x load cells``: cells with two or more sweeps
  (points) rotate them over the folds, offset per cell so that no fold holds out one speed or
  one slip range everywhere; single-unit cells always train;
- ``k interleaved point folds``: no cell has two units (one point per condition).
"""
from __future__ import annotations

import numpy as np

from identify.discover.noise import Sweeps
from identify.fit.solve.problem import FitProblem

__all__ = ["levels", "condition_cells", "pressure_is_crossed", "folds", "LEVEL_REL_GAP",
           "SCHEMES", "overlap"]

LEVEL_REL_GAP = 0.05
"""Two load values belong to different levels when they differ by more than this fraction."""
MAX_FOLDS = 5


def levels(values: np.ndarray, rel_gap: float = LEVEL_REL_GAP) -> np.ndarray:
    """Level number of each value: sorted values split where the gap exceeds ``rel_gap`` of
    their magnitude (1-D single linkage). NaN values form level -1."""
    v = np.asarray(values, dtype=float)
    out = np.full(v.size, -1, dtype=np.int64)
    ok = np.isfinite(v)
    if not ok.any():
        return out
    order = np.argsort(v[ok], kind="stable")
    s = v[ok][order]
    gap = np.diff(s) > rel_gap * np.maximum(np.abs(s[1:]), 1e-12)
    lv = np.concatenate([[0], np.cumsum(gap)])
    tmp = np.empty(s.size, dtype=np.int64)
    tmp[order] = lv
    out[ok] = tmp
    return out


def _per_sweep_mean(x: np.ndarray, sweeps: Sweeps) -> np.ndarray:
    """Each point's sweep mean of ``x`` (points in no sweep keep their own value)."""
    out = np.asarray(x, dtype=float).copy()
    if len(sweeps):
        inside = sweeps.label >= 0
        means = sweeps.sums(np.where(inside, out, 0.0)) / sweeps.sizes
        run = np.cumsum(sweeps.first) - 1
        out[inside] = means[run[inside]]
    return out


def condition_cells(problem: FitProblem, sweeps: Sweeps) -> tuple[np.ndarray, np.ndarray]:
    """(pressure level, other-condition level) of each point.

    The other condition is the load level (sweep-mean load, clustered) combined with the
    characteristic of the point (``extra["metric_group"]``, e.g. the sweep shape) when given.
    """
    n = problem.measured.size
    pres = np.unique(np.round(problem.pressure_bar, 4), return_inverse=True)[1]
    other = np.zeros(n, dtype=np.int64)
    fz = problem.extra.get("Fz_N")
    if fz is not None:
        other = levels(_per_sweep_mean(np.asarray(fz, dtype=float), sweeps)) + 1
    shape = problem.extra.get("metric_group")
    if shape is not None:
        lab = np.unique(np.asarray(shape).astype(str), return_inverse=True)[1]
        other = other * (int(lab.max()) + 1) + lab
    return pres, np.unique(other, return_inverse=True)[1]


def pressure_is_crossed(pres: np.ndarray, other: np.ndarray) -> bool:
    """True when every other-condition level measured at a pressure level is also measured at
    another pressure level (leaving any one pressure out keeps every other condition)."""
    seen = np.zeros((int(pres.max()) + 1, int(other.max()) + 1), dtype=bool)
    seen[pres, other] = True
    at_levels = seen.sum(axis=0)
    return bool(np.all(at_levels[seen.any(axis=0)] >= 2))


def overlap(pres: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Bool per point: its other-condition level is measured at two or more pressure levels
    (the part of a partly crossed design where a pressure law is seen at fixed conditions:
    the usual TTC layout measures some loads at several pressures, not every load)."""
    seen = np.zeros((int(pres.max()) + 1, int(other.max()) + 1), dtype=bool)
    seen[pres, other] = True
    return seen.sum(axis=0)[other] >= 2


SCHEMES = ("auto", "pressure", "cells", "rows")
"""Held-out schemes: chosen from the design, or forced."""


def folds(problem: FitProblem, index, max_folds: int = MAX_FOLDS, scheme: str = "auto"
          ) -> tuple[list[np.ndarray], str]:
    """Held-out folds (bool masks of held-out points) and the scheme's name (module doc).

    ``scheme`` forces one: ``"pressure"`` (leave one pressure level out, with two or more
    levels), ``"cells"`` (k-fold within condition cells), ``"rows"`` (interleaved points).
    """
    if scheme not in SCHEMES:
        raise ValueError(f"unknown held-out scheme {scheme!r}; choose from {SCHEMES}")
    n = problem.measured.size
    sweeps = Sweeps.of(index, n)
    pres, other = condition_cells(problem, sweeps)
    crossed = pressure_is_crossed(pres, other)
    n_pres = int(pres.max()) + 1
    if (scheme == "auto" and n_pres >= 3 and crossed) or (scheme == "pressure" and n_pres >= 2):
        return ([pres == lv for lv in range(n_pres)], "leave one pressure level out"
                + ("" if scheme == "auto" else " (forced)"))
    shared = overlap(pres, other)
    if scheme == "auto" and n_pres >= 3 and not crossed:
        at = [(pres == lv) & shared for lv in range(n_pres)]
        at = [m for m in at if m.any()]
        if len(at) >= 3:
            return at, ("leave one pressure level out of the conditions measured at several "
                        "pressures (the others always train)")
    why = ("forced" if scheme != "auto" else "fewer than three pressure levels"
           if crossed or shared.any() else "pressure not varied independently of load")
    real = len(sweeps) and bool(np.any(sweeps.sizes > 1))
    # units: whole sweeps when there are sweeps, else points
    unit = np.where(sweeps.label >= 0, np.cumsum(sweeps.first) - 1, -1) if real \
        else np.arange(n)
    cell = pres * (int(other.max()) + 1) + other
    first = np.unique(unit[unit >= 0], return_index=True)[1]
    u_ids = unit[unit >= 0][first]
    u_cell = cell[unit >= 0][first]
    # rank of each unit within its cell, and the cell's unit count
    order = np.lexsort((u_ids, u_cell))
    c_sorted = u_cell[order]
    start = np.r_[0, np.flatnonzero(np.diff(c_sorted)) + 1]
    counts = np.diff(np.r_[start, c_sorted.size])
    rank_sorted = np.arange(c_sorted.size) - np.repeat(start, counts)
    count_sorted = np.repeat(counts, counts)
    cell_no = np.repeat(np.arange(start.size), counts)
    multi = counts.max() if counts.size else 0
    what = "sweeps" if real else "rows"
    if multi >= 2 and scheme != "rows":
        k = int(min(max_folds, multi))
        # rotate each cell's units over the folds (offset per cell); a cell of c >= 2 units
        # loses at most ceil(c / k) < c of them to any fold, so it always trains
        fold_sorted = np.where(count_sorted >= 2, (rank_sorted + cell_no) % k, -1)
        fold_of_unit = np.full(int(u_ids.max()) + 1, -1)
        fold_of_unit[u_ids[order]] = fold_sorted
        point_fold = np.where(unit >= 0, fold_of_unit[np.maximum(unit, 0)], -1)
        masks = [point_fold == i for i in range(k)]
        masks = [m for m in masks if m.any()]
        return masks, f"{len(masks)}-fold over {what} within pressure x load cells ({why})"
    k = min(max_folds, n)
    return ([np.arange(n) % k == i for i in range(k)],
            f"{k} interleaved point folds ({why}; one point per condition)")
