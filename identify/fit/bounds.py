"""Which fit bounds are physics and which are only a search range, and how the latter widen.

The parameter table (identify.model.parameter_table.csv) gives every coefficient a range. Some
ends of those ranges encode physics, a sign or a shape the equations need: a stiffness or a
peak factor is not negative, a curvature E <= 1 (beyond it the curve folds back), a shape
factor C in [1, 2] (a force that saturates and never reverses). Those ends are **physical**
(:data:`PHYSICAL`): an optimum there is a result (the data ask for the limit case, e.g. no
nonlinear part of the rolling radius at DREFF = 0) and is reported as at a physical bound.
Every other end is **arbitrary**: a search range sized for a passenger-car tyre near 4 kN
(PKY1 up to 150 Fz0, PDY1 up to 3). On an FSAE tyre at a few hundred newtons, or a truck tyre,
an optimum can lie beyond it; the bound then is no result, so the MF stages widen it
(:func:`widen`) and solve again, at most :data:`MAX_WIDENINGS` times, and a coefficient still
at an arbitrary bound after that is held at its start (the data do not bound it) rather than
reported at a value the range put it at (identify.fit.mf.stages).

For a coefficient whose bounds apply to the magnitude (identify.model.parameters.bounds), the
kinds refer to the magnitude's lower and upper end and are mirrored with the sign.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

from identify.model.parameters import bounds, spec

__all__ = ["PHYSICAL", "ARBITRARY", "PHYSICAL_ENDS", "MAX_WIDENINGS", "WIDEN_FACTOR",
           "bound_kinds", "start_bounds", "widen", "side_at", "near_bound", "arbitrary_hits",
           "AT_BOUND_RTOL"]

PHYSICAL = "physical"
ARBITRARY = "arbitrary"

PHYSICAL_ENDS: Mapping[str, tuple[bool, bool]] = {
    # stiffnesses, peak and slope factors: not negative
    "VERTICAL_STIFFNESS": (True, False), "LONGITUDINAL_STIFFNESS": (True, False),
    "LATERAL_STIFFNESS": (True, False), "YAW_STIFFNESS": (True, False),
    "PKX1": (True, False), "QDZ1": (True, False), "QBZ1": (True, False),
    "RBX1": (True, False), "RBX2": (True, False), "RBY1": (True, False),
    "RBY2": (True, False), "QSY1": (True, False),
    # effective rolling radius: Re falls with load through DREFF atan(BREFF x) (the sign pair
    # of the mirror image (DREFF, BREFF) -> (-DREFF, -BREFF) fixed to +)
    "DREFF": (True, False), "BREFF": (True, False),
    # vertical load law: Q_FZ2 >= 0 (its floor 1e-4 stands for 0, where MF 6.1's deflection
    # is 0/0); the stiffness rises with pressure
    "Q_FZ2": (True, False), "PFZ1": (True, False),
    "PCFX3": (True, False), "PCFY3": (True, False),
    # contact patch: lengths and widths grow with load
    "Q_RA1": (True, False), "Q_RA2": (True, False), "Q_RB1": (True, False),
    # shape factors: C >= 1 saturates, C <= 2 never reverses the force
    "PCX1": (True, True), "PCY1": (True, True),
    # curvatures: E <= 1 (beyond it the curve folds back on itself)
    "PEX1": (False, True), "PEY1": (False, True), "REX1": (False, True),
    "REY1": (False, True), "QEZ1": (False, True),
    # pressure terms, the thesis's ranges (docs/relations.md): a factor (1 + PPX1 dpi + ...)
    # of a stiffness or a friction turns negative at dpi = -1/3 for +-3 (two thirds of the
    # nominal pressure), and (1 + PPY5 dpi) of the camber stiffness at dpi = 1 for -1; the
    # signs are the trends the thesis measured (camber thrust, camber torque and rolling
    # resistance fall with pressure)
    **{n: (True, True) for n in ("PPX1", "PPX2", "PPX3", "PPX4", "PPY1", "PPY2", "PPY3",
                                 "PPY4", "PPZ1", "PPMX1", "QSY7")},
    "PPY5": (True, True), "PPZ2": (True, True), "QSY8": (True, True),
}
"""Coefficient -> (lower end physical, upper end physical); every other end is arbitrary."""

MAX_WIDENINGS = 3
"""Times an MF stage widens the arbitrary bounds its optimum reaches and solves again."""
WIDEN_FACTOR = 4.0
"""An arbitrary end moves out to make the range this many times as wide; an end between the
other and zero (a positive lower end, a negative upper end: the sign is physics, its distance
from zero is not) moves to this fraction of its distance from zero instead."""


def bound_kinds(name: str, value: float | None = None) -> tuple[str, str]:
    """(kind of the lower bound, kind of the upper bound) of ``name`` at ``value`` (the sign
    of a magnitude bound): :data:`PHYSICAL` or :data:`ARBITRARY`."""
    lo, hi = PHYSICAL_ENDS.get(name, (False, False))
    kinds = (PHYSICAL if lo else ARBITRARY, PHYSICAL if hi else ARBITRARY)
    if spec(name).magnitude_bounds and value is not None and value < 0:
        kinds = kinds[::-1]
    return kinds


def start_bounds(name: str, value: float) -> tuple[float, float]:
    """The bounds an MF stage starts ``name`` with at the start ``value``: the table's, with an
    arbitrary end that the start lies beyond moved past it (to twice the start's distance
    from the other end), so that a start scaled from the data (an FSAE tyre's cornering
    stiffness) is not clipped to a passenger-car range; a physical end clips the start."""
    lo, hi = bounds(name, value)
    k_lo, k_hi = bound_kinds(name, value)
    if math.isfinite(value):
        if value > hi and k_hi == ARBITRARY:
            hi = value + (value - lo if math.isfinite(lo) else abs(value))
        elif value < lo and k_lo == ARBITRARY:
            lo = value - (hi - value if math.isfinite(hi) else abs(value))
    return lo, hi


def widen(lo: float, hi: float, side: str) -> tuple[float, float]:
    """(lo, hi) with its ``side`` end ("lower" or "upper") widened (:data:`WIDEN_FACTOR`)."""
    span = (hi - lo) * (WIDEN_FACTOR - 1.0)
    if side == "upper":
        return lo, (hi / WIDEN_FACTOR if hi < 0 else hi + span)
    return (lo / WIDEN_FACTOR if lo > 0 else lo - span), hi


def side_at(value: float, lo: float, hi: float) -> str:
    """"lower" or "upper": the bound ``value`` sits at (the nearer one)."""
    return "lower" if abs(value - lo) <= abs(value - hi) else "upper"


AT_BOUND_RTOL = 1e-6
"""A value within this fraction of its range from a bound is at it (a solver stops a hair
inside a bound it runs to)."""


def near_bound(value: float, lo: float, hi: float) -> bool:
    """Whether ``value`` is at ``lo`` or ``hi`` (within AT_BOUND_RTOL of the finite range)."""
    span = hi - lo if math.isfinite(lo) and math.isfinite(hi) else max(abs(value), 1.0)
    tol = AT_BOUND_RTOL * span
    return value <= lo + tol or value >= hi - tol


def arbitrary_hits(free, parameters: Mapping[str, float],
                   bounds_of: Mapping[str, tuple[float, float]]) -> dict[str, str]:
    """Coefficients of ``free`` at an arbitrary end of their bounds (:func:`near_bound`) ->
    that side."""
    out = {}
    for n in free:
        lo, hi = bounds_of.get(n, (-math.inf, math.inf))
        v = float(parameters[n])
        if not near_bound(v, lo, hi):
            continue
        side = side_at(v, lo, hi)
        if bound_kinds(n, v)[0 if side == "lower" else 1] == ARBITRARY:
            out[n] = side
    return out
