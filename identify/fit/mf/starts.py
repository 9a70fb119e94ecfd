"""Start values of the MF force stages scaled from the data, so that the search starts at the
tyre that was measured, not at a passenger-car tyre.

The parameter table's defaults describe a passenger-car tyre near 4 kN (friction 1.1-1.3,
cornering stiffness 20 Fz0). The global search of a stage looks within +/-50 % of its start
(identify.fit.mf.search.BOX); an FSAE slick on a TTC belt (friction 2-3, a cornering
stiffness of 50-150 Fz0 at a few hundred newtons) or a truck tyre lies outside. Four numbers
are read off the data near the nominal load FNOMIN (within :data:`LOAD_BAND` of it):

* PDY1, PDX1: the friction, the 99th percentile of |Fy|/Fz (|Fx|/Fz) of the pure-slip points
  beyond the linear range (|alpha| > :data:`SMALL_ALPHA`, |kappa| > :data:`SMALL_KAPPA`: the
  free-rolling points of the other runs carry no friction);
* PKY1: the cornering stiffness Kya/FNOMIN, the slope dFy/dalpha of a straight line through
  the points within :data:`SMALL_ALPHA` of zero slip at zero camber (the MF's Kya at FNOMIN
  is PKY1 FNOMIN with the defaults PKY2 = 1, PKY4 = 2), with its sign (the axis convention);
* PKX1: the longitudinal slip stiffness Kxk/FNOMIN, the slope dFx/dkappa within
  :data:`SMALL_KAPPA`.

A start is replaced only where the data's value lies outside the search's reach, more than a
factor :data:`FACTOR` from it: a start that already describes the tyre stays as it is.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from identify.fit.mf.stage_specs import PURE_ALPHA, PURE_KAPPA

__all__ = ["LOAD_BAND", "SMALL_ALPHA", "SMALL_KAPPA", "FACTOR", "MIN_POINTS", "data_starts"]

LOAD_BAND = 0.25
"""Points within this fraction of FNOMIN of it count as at the nominal load."""
SMALL_ALPHA = np.deg2rad(1.0)
"""[rad] The linear range of the lateral force for the cornering stiffness."""
SMALL_KAPPA = 0.02
"""[-] The linear range of the longitudinal force for the slip stiffness."""
FACTOR = 2.0
"""A start is replaced when the data's value is more than this factor from it (the search's
box of +/-50 % does not reach it)."""
MIN_POINTS = 8
"""Fewest points for an estimate: one binned sweep's linear range (the bins of 0.25 deg within
+-1 deg, identify.workflows.sweep_bins)."""


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y on x (NaN with fewer than MIN_POINTS or no spread)."""
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < MIN_POINTS:
        return float("nan")
    xc = x - x.mean()
    den = float(xc @ xc)
    return float(xc @ (y - y.mean())) / den if den > 0 else float("nan")


def _friction(force: np.ndarray, fz: np.ndarray) -> float:
    """The 99th percentile of |force|/Fz (NaN with fewer than MIN_POINTS)."""
    ok = np.isfinite(force) & np.isfinite(fz) & (fz > 0)
    if ok.sum() < MIN_POINTS:
        return float("nan")
    return float(np.quantile(np.abs(force[ok]) / fz[ok], 0.99))


def _estimates(trailer: pd.DataFrame, fnomin: float) -> dict[str, float]:
    """PDY1, PKY1, PDX1, PKX1 as the data show them (NaN where they cannot)."""
    col = {c: trailer[c].to_numpy(float) for c in ("Fz", "alpha", "kappa", "gamma")
           if c in trailer}
    fz, alpha, kappa = col["Fz"], col["alpha"], col["kappa"]
    gamma = col.get("gamma", np.zeros_like(fz))
    near = np.abs(fz - fnomin) <= LOAD_BAND * fnomin
    flat = np.abs(gamma) <= np.deg2rad(0.5)
    out = {}
    if "Fy" in trailer:
        out["PDY1"], out["PKY1"] = _friction_and_slope(
            trailer["Fy"].to_numpy(float), fz, alpha, near & (np.abs(kappa) <= PURE_KAPPA),
            flat, SMALL_ALPHA)
    if "Fx" in trailer:
        out["PDX1"], out["PKX1"] = _friction_and_slope(
            trailer["Fx"].to_numpy(float), fz, kappa, near & (np.abs(alpha) <= PURE_ALPHA),
            flat, SMALL_KAPPA)
    return out


def _friction_and_slope(force: np.ndarray, fz: np.ndarray, slip: np.ndarray,
                        pure: np.ndarray, flat: np.ndarray, small: float) -> tuple[float, float]:
    """The friction coefficient and the slip stiffness per unit load of one pure-slip force.

    force, fz : ndarray [N]; slip : ndarray [rad or -], the swept slip; pure : the samples of
    pure slip near the nominal load; flat : the samples near zero camber; small : the slip
    bounding the linear range. The friction is taken where the force saturates, beyond the
    linear range (a run's free-rolling points at zero slip are no friction sample); the slope
    per unit load, so that the loads within the band average out.
    """
    past = pure & (np.abs(slip) > small)
    lin = pure & flat & (np.abs(slip) <= small)
    return _friction(force[past], fz[past]), _slope(slip[lin], force[lin] / fz[lin])


def data_starts(trailer: pd.DataFrame, params: Mapping[str, float]) -> dict[str, float]:
    """The starts of PDY1, PKY1, PDX1, PKX1 to replace (module docstring): name -> the
    data's magnitude with the start's sign, for those whose start ``params[name]`` is more
    than FACTOR from it in magnitude."""
    fnomin = float(params["FNOMIN"])
    out = {}
    for name, value in _estimates(trailer, fnomin).items():
        if not np.isfinite(value) or value == 0:
            continue
        start = float(params[name])
        if name == "PKX1" and value < 0:
            continue  # a slip-ratio sign convention the Fx0 stage does not take
        ratio = abs(value) / abs(start) if start else np.inf
        if not 1.0 / FACTOR <= ratio <= FACTOR:
            # the magnitude from the data, the sign of the start (PKY1's sign goes with
            # PKY4's: identify.model.symmetries; the stage finds the image the data ask for)
            out[name] = float(abs(value)) * (-1.0 if start < 0 else 1.0)
    return out
