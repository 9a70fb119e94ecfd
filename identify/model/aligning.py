"""Aligning moment Mz (docs/model.md, section 7: 4.E31-4.E47, 4.E71-4.E78, paper A54-A60).

MFeval exports only the combined form: Mz = -t*F'y + Mzr + s*Fx, even at kappa = 0.
Pure vectorised functions; no I/O. ``xp`` is the array module
(numpy by default; jax.numpy for the MF stages' exact derivatives, identify.fit.mf.jacobian).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.model.lateral import CombinedLateral, PureLateral
from identify.model.state import EPS, OperatingState, sgn1


@dataclass(frozen=True)
class AligningMoment:
    """Combined aligning moment and its exported pieces.

    Attributes
    ----------
    mz : ndarray [N m]
    t : ndarray [m]       pneumatic trail
    mzr : ndarray [N m]   residual moment
    """

    mz: np.ndarray
    t: np.ndarray
    mzr: np.ndarray


def residual_slip(s: OperatingState, fy_pure: PureLateral, kxk: np.ndarray, xp=np
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(r2, alpha_r,eq) of :func:`mz`: (Kxk / Kya')^2 kappa^2 [-] and the equivalent slip
    angle of the residual moment [rad] (4.E77, 4.E78). They read the operating points and the
    forces' Kya, Kxk and shifts, no Mz coefficient: a fit of Mz coefficients with the forces
    held computes them once and passes them to every evaluation (``slip``), the same numbers
    as computed there."""
    kya = fy_pure.kya
    kya_p = kya + EPS * sgn1(kya, xp)
    alpha_r = s.alpha_star + fy_pure.shy + fy_pure.svy / kya_p
    r2 = (kxk / kya_p) ** 2 * s.kappa ** 2
    return r2, xp.arctan(xp.sqrt(xp.tan(alpha_r) ** 2 + r2)) * xp.sign(alpha_r)


def mz(P: Mapping[str, float], s: OperatingState, fy_pure: PureLateral,
       fy_pure_zero_camber: PureLateral, fy: CombinedLateral, fx: np.ndarray,
       kxk: np.ndarray, xp=np, slip: tuple[np.ndarray, np.ndarray] | None = None
       ) -> AligningMoment:
    """Combined aligning moment Mz [N m].

    Parameters
    ----------
    fy_pure : PureLateral          Fy0 with the actual camber (shifts, Kya, By, Cy)
    fy_pure_zero_camber : PureLateral  Fy0 at gamma = 0 (the force the trail acts on)
    fy : CombinedLateral           combined Fy and Gyk
    fx : ndarray [N]               combined Fx
    kxk : ndarray [N]              longitudinal slip stiffness
    slip : (ndarray, ndarray), optional
        :func:`residual_slip` of the same points and forces, computed once by the caller.
    """
    dfz, dpi, g, a, gamma = s.dfz, s.dpi, s.gamma_star, s.alpha_star, s.gamma
    r0, fz0p = P["UNLOADED_RADIUS"], s.fz0p
    if s.mode.limits:
        fz_m = xp.where(s.fz <= 0, 0.0, s.fz_low)
    else:
        fz_m = s.fz
    sht = P["QHZ1"] + P["QHZ2"] * dfz + (P["QHZ3"] + P["QHZ4"] * dfz) * g
    alpha_t = a + sht
    dt = ((P["QDZ1"] + P["QDZ2"] * dfz) * (1 - P["PPZ1"] * dpi)
          * (1 + P["QDZ3"] * gamma + P["QDZ4"] * gamma ** 2)
          * fz_m * (r0 / fz0p) * P["LTR"])
    bt = ((P["QBZ1"] + P["QBZ2"] * dfz + P["QBZ3"] * dfz ** 2)
          * (1 + P["QBZ4"] * gamma + P["QBZ5"] * xp.abs(gamma)) * P["LKY"] / P["LMUY"])
    ct = P["QCZ1"]
    et = ((P["QEZ1"] + P["QEZ2"] * dfz + P["QEZ3"] * dfz ** 2)
          * (1 + (P["QEZ4"] + P["QEZ5"] * g) * (2 / np.pi) * xp.arctan(bt * ct * alpha_t)))
    if s.mode.limits:
        et = xp.minimum(et, 1.0)
    dr = (fz_m * r0 * ((P["QDZ6"] + P["QDZ7"] * dfz) * P["LRES"]
                       + ((P["QDZ8"] + P["QDZ9"] * dfz) * (1 + P["PPZ2"] * dpi)
                          + (P["QDZ10"] + P["QDZ11"] * dfz) * xp.abs(g)) * g * P["LKZC"])
          * P["LMUY"] * xp.sign(s.vx_u) * xp.cos(a))
    br = P["QBZ9"] * P["LKY"] / P["LMUY"] + P["QBZ10"] * fy_pure.by * fy_pure.cy

    r2, alpha_r_eq = residual_slip(s, fy_pure, kxk, xp) if slip is None else slip
    alpha_t_eq = xp.arctan(xp.sqrt(xp.tan(alpha_t) ** 2 + r2)) * xp.sign(alpha_t)
    arm = r0 * (P["SSZ1"] + P["SSZ2"] * (fy.fy / P["FNOMIN"])
                + (P["SSZ3"] + P["SSZ4"] * dfz) * gamma) * P["LS"]
    mzr = dr * xp.cos(xp.arctan(br * alpha_r_eq)) * s.ws
    fy_prime = fy.gyk * fy_pure_zero_camber.fy0
    bta = bt * alpha_t_eq
    t = (dt * xp.cos(ct * xp.arctan(bta - et * (bta - xp.arctan(bta)))) * s.cos_alpha_p
         * P["LFZO"] * s.ws)
    return AligningMoment(mz=-t * fy_prime + mzr + arm * fx, t=t, mzr=mzr)
