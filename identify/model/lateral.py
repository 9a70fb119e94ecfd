"""Lateral force: pure slip Fy0 (MF 6.1, 4.E19-4.E30) and combined Fy (4.E58-4.E67).

Pure vectorised functions; no I/O. ``xp`` is the array module (numpy by default; jax.numpy
for the exact derivatives of the MF stage fits, identify.fit.mf.jacobian).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.model.longitudinal import magic_cosine, magic_sine
from identify.model.state import EPS, OperatingState, sgn1


@dataclass(frozen=True)
class PureLateral:
    """Fy0 and the pieces the aligning moment and combined slip reuse.

    Attributes
    ----------
    fy0 : ndarray [N]
    muy : ndarray [-]     friction coefficient (0 where Fz = 0; signed)
    kya : ndarray [N/rad] cornering stiffness
    shy, svy : ndarray    horizontal [rad] and vertical [N] shifts (after the low-speed factor)
    by, cy : ndarray      stiffness and shape factors [-]
    """

    fy0: np.ndarray
    muy: np.ndarray
    kya: np.ndarray
    shy: np.ndarray
    svy: np.ndarray
    by: np.ndarray
    cy: float


def fy0(P: Mapping[str, float], s: OperatingState, zero_camber: bool = False,
        xp=np) -> PureLateral:
    """Pure side-slip force Fy0 [N] (docs/model.md, section 5).

    Parameters
    ----------
    zero_camber : bool
        Evaluate with gamma = gamma* = 0 ("Fy0 at zero camber", used by both Mz blocks);
        load, pressure, alpha* and the low-speed factor are unchanged.
    """
    dfz, dpi, fz, fz0p = s.dfz, s.dpi, s.fz, s.fz0p
    g = 0.0 if zero_camber else s.gamma_star
    kya = (P["PKY1"] * fz0p * (1 + P["PPY1"] * dpi) * (1 - P["PKY3"] * xp.abs(g))
           * xp.sin(P["PKY4"] * xp.arctan((fz / fz0p)
                                          / ((P["PKY2"] + P["PKY5"] * g ** 2)
                                             * (1 + P["PPY2"] * dpi))))
           * P["LKY"])
    svyg = fz * (P["PVY3"] + P["PVY4"] * dfz) * g * P["LKYC"] * P["LMUY"]
    kyg0 = fz * (P["PKY6"] + P["PKY7"] * dfz) * (1 + P["PPY5"] * dpi) * P["LKYC"]
    shy = ((P["PHY1"] + P["PHY2"] * dfz) * P["LHY"]
           + (kyg0 * g - svyg) / (kya + EPS * sgn1(kya, xp)))
    svy = fz * (P["PVY1"] + P["PVY2"] * dfz) * P["LVY"] * P["LMUY"] + svyg
    shy = shy * s.ws
    svy = svy * s.ws
    alpha_y = s.alpha_star + shy
    cy = P["PCY1"] * P["LCY"]
    muy = ((P["PDY1"] + P["PDY2"] * dfz) * (1 + P["PPY3"] * dpi + P["PPY4"] * dpi ** 2)
           * (1 - P["PDY3"] * g ** 2) * P["LMUY"])
    dy = muy * fz
    ey = ((P["PEY1"] + P["PEY2"] * dfz)
          * (1 + P["PEY5"] * g ** 2 - (P["PEY3"] + P["PEY4"] * g) * sgn1(alpha_y, xp)) * P["LEY"])
    if s.mode.limits:
        ey = xp.minimum(ey, 1.0)
    by = kya / (cy * dy + EPS * sgn1(dy, xp))
    f = magic_sine(by, cy, dy, ey, alpha_y, xp) + svy
    if s.mode.alpha_star:
        f = xp.where(s.vx_u < 0, -f, f)
    muy = xp.where(fz == 0, 0.0, muy)
    return PureLateral(fy0=f, muy=muy, kya=kya, shy=shy, svy=svy, by=by, cy=cy)


@dataclass(frozen=True)
class CombinedLateral:
    """Combined-slip lateral force.

    Attributes
    ----------
    fy : ndarray [N]   Gyk * Fy0 + SVyk
    gyk : ndarray [-]  weighting function (with the actual gamma*)
    """

    fy: np.ndarray
    gyk: np.ndarray


def fy_combined(P: Mapping[str, float], s: OperatingState, pure: PureLateral,
                xp=np) -> CombinedLateral:
    """Combined-slip lateral force Fy [N] (docs/model.md, section 6)."""
    dfz, g, a = s.dfz, s.gamma_star, s.alpha_star
    dvyk = (pure.muy * s.fz * (P["RVY1"] + P["RVY2"] * dfz + P["RVY3"] * g)
            * xp.cos(xp.arctan(P["RVY4"] * a)))
    svyk = dvyk * xp.sin(P["RVY5"] * xp.arctan(P["RVY6"] * s.kappa)) * P["LVYKA"] * s.ws
    shyk = P["RHY1"] + P["RHY2"] * dfz
    eyk = P["REY1"] + P["REY2"] * dfz
    if s.mode.limits:
        eyk = xp.minimum(eyk, 1.0)
    cyk = P["RCY1"]
    byk = ((P["RBY1"] + P["RBY4"] * g ** 2) * xp.cos(xp.arctan(P["RBY2"] * (a - P["RBY3"])))
           * P["LYKA"])
    gyk = magic_cosine(byk, cyk, eyk, s.kappa + shyk, xp) / magic_cosine(byk, cyk, eyk, shyk, xp)
    return CombinedLateral(fy=gyk * pure.fy0 + svyk, gyk=gyk)
