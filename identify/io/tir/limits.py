"""What a .tir's own limits and sections say about evaluating it: broken limit pairs, whole
coefficient sections left out, operating points outside the ranges it declares valid.

``mfid eval`` refuses a file whose limit pair is inverted (a minimum above its maximum: no
point lies in the range) and warns, naming the keys, of a force or moment coefficient section
that is missing altogether (all its keys take their defaults, so the tyre evaluated is not the
file's) and of points outside the file's ranges (the model extrapolates, or clips with limit
checks on, where the file claims nothing).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.io.tir.read import TirFile
from identify.model.parameters import PARAMETERS

__all__ = ["COEFFICIENT_SECTIONS", "LIMIT_PAIRS", "LimitPair", "Outside", "inverted_limits",
           "missing_sections", "points_outside"]


@dataclass(frozen=True)
class LimitPair:
    """A range a .tir declares valid: its two keys, the input column (``mfid eval``'s points)
    it bounds and that column's unit (SI)."""

    low: str
    high: str
    column: str
    unit: str


LIMIT_PAIRS = (
    LimitPair("FZMIN", "FZMAX", "Fz", "N"),
    LimitPair("KPUMIN", "KPUMAX", "kappa", "-"),
    LimitPair("ALPMIN", "ALPMAX", "alpha", "rad"),
    LimitPair("CAMMIN", "CAMMAX", "gamma", "rad"),
    LimitPair("PRESMIN", "PRESMAX", "p", "Pa"),
)

COEFFICIENT_SECTIONS = ("LONGITUDINAL_COEFFICIENTS", "LATERAL_COEFFICIENTS",
                        "ALIGNING_COEFFICIENTS", "OVERTURNING_COEFFICIENTS",
                        "ROLLING_COEFFICIENTS")
"""The sections of the force and moment coefficients: one missing altogether is a tyre of
defaults, not of the file."""


@dataclass(frozen=True)
class Outside:
    """Points beyond one limit key: the key, its value and how many points pass it."""

    key: str
    value: float
    count: int


def inverted_limits(tir: TirFile) -> list[str]:
    """Every limit pair whose minimum is above its maximum, as ``"FZMIN = a > FZMAX = b"``."""
    out = []
    for pair in LIMIT_PAIRS:
        lo, hi = tir.values.get(pair.low), tir.values.get(pair.high)
        if isinstance(lo, float) and isinstance(hi, float) and lo > hi:
            out.append(f"{pair.low} = {lo:g} > {pair.high} = {hi:g}")
    return out


def missing_sections(tir: TirFile) -> dict[str, tuple[str, ...]]:
    """Section -> its keys, for every coefficient section none of whose keys is in the file."""
    defaulted = set(tir.defaults_used)
    out = {}
    for section in COEFFICIENT_SECTIONS:
        keys = tuple(p.name for p in PARAMETERS if p.section == section)
        if keys and all(k in defaulted for k in keys):
            out[section] = keys
    return out


def points_outside(tir: TirFile | Mapping[str, object], points) -> list[Outside]:
    """For every limit key, how many points lie beyond it (none listed: every point is
    inside). ``points``: a frame (or mapping) with ``mfid eval``'s columns [SI, rad]; a
    pressure of 0 stands for INFLPRES, as the model reads it. A key the file leaves out
    (its default) claims nothing and is not checked."""
    values = tir.values if isinstance(tir, TirFile) else tir
    defaulted = set(tir.defaults_used) if isinstance(tir, TirFile) else set()
    out = []
    for pair in LIMIT_PAIRS:
        if pair.column not in points:
            continue
        x = np.asarray(points[pair.column], dtype=float)
        if pair.column == "p":
            x = np.where(x == 0.0, float(values.get("INFLPRES", np.nan)), x)
        for key, beyond in ((pair.low, np.less), (pair.high, np.greater)):
            limit = values.get(key)
            if not isinstance(limit, float) or key in defaulted:
                continue
            n = int(np.count_nonzero(beyond(x, limit)))
            if n:
                out.append(Outside(key, limit, n))
    return out
