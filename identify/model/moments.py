"""Overturning moment Mx (TNO form) and rolling-resistance moment My (paper A48).

Pure vectorised functions; no I/O. Both apply MFeval's low-load reductions below FZMIN with or
without limit checks (docs/model.md, sections 8 and 9). ``xp`` is the array module (numpy by
default; jax.numpy for the MF stages' exact derivatives, identify.fit.mf.jacobian).
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from identify.model.state import OperatingState


def mx(P: Mapping[str, float], s: OperatingState, fy: np.ndarray, xp=np) -> np.ndarray:
    """Overturning moment Mx [N m] from the combined lateral force ``fy`` [N]."""
    fz0, gamma = P["FNOMIN"], s.gamma
    with np.errstate(divide="ignore", invalid="ignore"):  # FZMIN = 0: branch never taken
        fz = xp.where(s.fz < P["FZMIN"], s.fz * (s.fz / P["FZMIN"]) ** 2, s.fz)
    bracket = (P["QSX1"] * P["LVMX"] - P["QSX2"] * gamma * (1 + P["PPMX1"] * s.dpi)
               - P["QSX12"] * gamma * xp.abs(gamma) + P["QSX3"] * fy / fz0
               + P["QSX4"] * xp.cos(P["QSX5"] * xp.arctan((P["QSX6"] * fz / fz0) ** 2))
               * xp.sin(P["QSX7"] * gamma + P["QSX8"] * xp.arctan(P["QSX9"] * fy / fz0))
               + P["QSX10"] * xp.arctan(P["QSX11"] * fz / fz0) * gamma)
    return P["UNLOADED_RADIUS"] * P["LMX"] * (fz * bracket
                                             + fy * (P["QSX13"] + P["QSX14"] * xp.abs(gamma)))


def my(P: Mapping[str, float], s: OperatingState, fx: np.ndarray, xp=np) -> np.ndarray:
    """Rolling-resistance moment My [N m] from the combined longitudinal force ``fx`` [N].

    Uses the unlimited load, speed and slip; (Fz/Fz0)^QSY7 * (p/p0)^QSY8 scale the bracket.
    """
    fz0, v0, vx, vxlow = P["FNOMIN"], P["LONGVL"], s.vx_u, P["VXLOW"]
    with np.errstate(divide="ignore", invalid="ignore"):  # FZMIN = 0: branch never taken
        fz = xp.where(s.fz_u < P["FZMIN"], s.fz_u * (s.fz_u / P["FZMIN"]), s.fz_u)
    out = (-P["UNLOADED_RADIUS"] * fz0 * P["LMY"]
           * (P["QSY1"] + P["QSY2"] * fx / fz0 + P["QSY3"] * xp.abs(vx / v0)
              + P["QSY4"] * (vx / v0) ** 4 + (P["QSY5"] + P["QSY6"] * fz / fz0) * s.gamma ** 2)
           * (fz / fz0) ** P["QSY7"] * (s.p / P["NOMPRES"]) ** P["QSY8"])
    out = xp.where(vx < 0, -out, out)
    with np.errstate(divide="ignore", invalid="ignore"):
        hi = vxlow / xp.abs(vx) - 1
        lo = -1 - vxlow - hi
        k = s.kappa_u
        band = (k >= lo) & (k <= hi)
        shaped = out * xp.sin((np.pi / 2) * (k + 1) / (hi + 1))
    out = xp.where(band, shaped, out)
    out = xp.where(k < lo, -out, out)
    return xp.where(vx == 0, 0.0, out)
