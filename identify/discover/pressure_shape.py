"""The shape of a pressure candidate: its column with every point at one common pressure.

A pressure coefficient of the Magic Formula enters through dpi = (p - p0) / p0 (PPY1 scales the
cornering stiffness by 1 + PPY1 dpi, PPY4 the friction by 1 + PPY4 dpi^2, ...), so at its
neutral value its column d r / d c is a shape H, set by load, slip and camber, times a power of
each point's dpi. On the sweeps at the nominal pressure that column is zero; the shape is not.
Evaluated with every point moved to one pressure (dpi = :data:`SHAPE_DPI`), the column is H up
to a constant on every sweep, the nominal ones included, which is what the pooled score
variance of :func:`identify.discover.score.pooled_score_variance` needs.

A problem offers this through ``extra["at_pressure"]``: a callable ``(values, dpi) ->
FitProblem`` building the same problem, on the same points in the same order, with every
point's pressure at p0 (1 + dpi) (:func:`identify.discover.problems.trailer_problems`).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from identify.discover.library import Candidate
from identify.discover.objective import Objective
from identify.discover.prepared_problem import Working
from identify.fit.mf.pressure_holdout import is_pressure_coefficient

__all__ = ["SHAPE_DPI", "pressure_shapes"]

SHAPE_DPI = 0.2
"""Relative pressure offset at which the shapes are evaluated [-]. Any non-zero value gives
the same shape of a candidate linear in dpi, up to a constant; it only has to lie within the
pressures a tyre is measured at."""


def pressure_shapes(w: Working, candidates: Sequence[Candidate]) -> dict[str, np.ndarray]:
    """name -> (n,) shape column (transformed like the candidate columns) of every
    one-coefficient pressure candidate of ``w``; empty when the problem cannot move its
    points' pressure or its noise is not cluster-robust (the only test that uses shapes)."""
    at = w.problem.extra.get("at_pressure")
    if at is None or w.noise.kind != "cluster":
        return {}
    mine = [c for c in candidates if len(c.coefficients) == 1
            and is_pressure_coefficient(next(iter(c.coefficients)))]
    if not mine:
        return {}
    vals = w.problem.values(w.x)
    moved = at(vals, SHAPE_DPI)
    if moved is None or moved.measured.size != w.problem.measured.size:
        return {}
    shifted = dataclasses.replace(w.problem, model=moved.model, jacobian=moved.jacobian)
    obj = Objective(shifted, w.objective.index, w.objective.phi)
    out = {}
    for c in mine:
        col = np.asarray(obj.columns(w.x, {k: vals[k] for k in c.coefficients}), dtype=float)
        if np.all(np.isfinite(col)) and np.any(col):
            out[c.name] = col.reshape(-1)
    return out
