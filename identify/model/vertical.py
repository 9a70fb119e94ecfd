"""Vertical and geometric quantities: effective rolling radius and spin rate, deflection,
loaded radius and vertical stiffness (MF 6.1 closed form, MF 6.2 vectorised secant solve),
contact patch, and the MF-Swift overall stiffnesses and relaxation lengths
(docs/model.md, section 10). Pure vectorised functions; no I/O.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.model.state import OperatingState

RE_TOLERANCE = 1e-9
"""Stop test of MFeval's Re fixed point [m]."""
SECANT_MAX_UPDATES = 18
SECANT_TOLERANCE = 1e-6
"""MFeval 4.3 secant stop test |Fz(Rl) - Fz| <= SECANT_TOLERANCE * FNOMIN."""
EXACT_TOLERANCE = 1e-12
EXACT_MAX_UPDATES = 60


def free_radius(P: Mapping[str, float], omega: np.ndarray, xp=np) -> np.ndarray:
    """Free (centrifugally grown) radius R_omega [m] at spin rate ``omega`` [rad/s]."""
    r0 = P["UNLOADED_RADIUS"]
    return r0 * (P["Q_RE0"] + P["Q_V1"] * (omega * r0 / P["LONGVL"]) ** 2)


def _effective_radius(P, s: OperatingState, omega: np.ndarray, xp=np) -> np.ndarray:
    fz0 = P["FNOMIN"]
    cz = P["VERTICAL_STIFFNESS"] * (1 + P["PFZ1"] * s.dpi)
    return free_radius(P, omega, xp) - (fz0 / cz) * (
        P["DREFF"] * xp.arctan(P["BREFF"] * s.fz_u / fz0) + P["FREFF"] * s.fz_u / fz0)


def rolling_radius(P: Mapping[str, float], s: OperatingState, omega: np.ndarray | None = None,
                   per_point: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Effective rolling radius Re [m] and spin rate omega [rad/s].

    With ``omega`` given, Re = Re(omega + machine eps). Without it, the fixed point
    omega = (1 + kappa) Vx / Re is iterated from Re = 0.965 R0 until |Re_old - Re| <= 1e-9 m.

    Parameters
    ----------
    per_point : bool
        True (default): every point iterates until it has converged and is then frozen, so a
        point's result does not depend on which other points share the call; this equals
        MFeval called one point at a time. False: MFeval's vector semantics, where MATLAB's
        ``while`` on a vector stops as soon as ANY point has converged (equals one MFeval call
        over the same points; differences are ~1e-9 relative in omega).
    """
    if omega is not None:
        omega = np.asarray(omega, dtype=float) + np.finfo(float).eps
        return _effective_radius(P, s, omega), omega
    r0 = P["UNLOADED_RADIUS"]
    re = np.full(s.fz_u.shape, 0.965 * r0)
    re_old = np.full(s.fz_u.shape, r0)
    omega = np.zeros_like(re)
    active = np.abs(re_old - re) > RE_TOLERANCE
    for _ in range(100):  # converges in a handful of steps; the cap only guards bad data
        if per_point:
            if not active.any():
                break
        elif re.size == 0 or not active.all():
            break
        new_omega = (1 + s.kappa_u) * s.vx_u / re
        new_re = _effective_radius(P, s, new_omega)
        re_old = np.where(active, re, re_old)
        omega = np.where(active, new_omega, omega)
        re = np.where(active, new_re, re)
        active = active & (np.abs(re_old - re) > RE_TOLERANCE)
    return re, omega


@dataclass(frozen=True)
class Deflection:
    """Vertical deflection rho [m], loaded radius Rl [m] and vertical stiffness Cz [N/m].

    ``converged`` is False where the MF 6.2 solve found no root of Fz(Rl) = Fz within its
    update limit (always True for the closed-form MF 6.1).
    """

    rho: np.ndarray
    rl: np.ndarray
    cz: np.ndarray
    converged: np.ndarray


def _qfz1(P) -> float:
    return float(np.sqrt((P["VERTICAL_STIFFNESS"] * P["UNLOADED_RADIUS"] / P["FNOMIN"]) ** 2
                         - 4 * P["Q_FZ2"]))


def deflection_61(P: Mapping[str, float], s: OperatingState, fx: np.ndarray, fy: np.ndarray,
                  omega: np.ndarray) -> Deflection:
    """MF 6.1: solve the load-deflection quadratic in closed form for the load Fz_low."""
    r0, fz0, qfz2 = P["UNLOADED_RADIUS"], P["FNOMIN"], P["Q_FZ2"]
    qfz1 = _qfz1(P)
    e = ((1 + P["Q_V2"] * (r0 / P["LONGVL"]) * np.abs(omega) - (P["Q_FCX"] * fx / fz0) ** 2
          - (P["Q_FCY"] * fy / fz0) ** 2) * (1 + P["PFZ1"] * s.dpi) * fz0)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (-qfz1 + np.sqrt(qfz1 ** 2 + 4 * qfz2 * s.fz_low / e)) / (2 * qfz2)
    rho = np.fmax(x * r0, 0.0)  # fmax: Q_FZ2 = 0 gives 0/0, MATLAB's max drops the NaN
    rl = np.fmax(free_radius(P, omega) - rho, 0.0)
    rho = np.where(s.fz_low == 0, 1e-6, rho)
    with np.errstate(divide="ignore"):
        cz = s.fz_low / rho
    return Deflection(rho=rho, rl=rl, cz=cz, converged=np.ones(rho.shape, bool))


def _load_62(P, s: OperatingState, fx, fy, omega, r_omega, rl):
    """MF 6.2 vertical force Fz(Rl) [N] and the deflection rho(Rl) [m] at loaded radius rl."""
    r0, fz0, gamma = P["UNLOADED_RADIUS"], P["FNOMIN"], s.gamma
    ratio = rl / r_omega
    sfyg = (P["Q_FYS1"] + P["Q_FYS2"] * ratio + P["Q_FYS3"] * ratio ** 2) * gamma
    rho_fr = np.maximum(r_omega - rl, 0.0)
    rtw = (1.075 - 0.5 * P["ASPECT_RATIO"]) * P["WIDTH"]
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_g = (((P["Q_CAM1"] * rl + P["Q_CAM2"] * rl ** 2) * gamma) ** 2 * (rtw / 8)
                 * np.abs(np.tan(gamma))
                 / ((P["Q_CAM1"] * r_omega + P["Q_CAM2"] * r_omega ** 2) * gamma) ** 2
                 - P["Q_CAM3"] * rho_fr * np.abs(gamma))
    rho_g = np.where(np.isnan(rho_g), 0.0, rho_g)
    rho = np.maximum(rho_fr + rho_g, 1e-12)
    x = rho / r0
    fcorr = ((1 + P["Q_V2"] * (r0 / P["LONGVL"]) * np.abs(omega) - (P["Q_FCX"] * fx / fz0) ** 2
              - (x ** P["Q_FCY2"] * P["Q_FCY"] * (fy - sfyg) / fz0) ** 2)
             * (1 + P["PFZ1"] * s.dpi))
    return fcorr * (_qfz1(P) * x + P["Q_FZ2"] * x ** 2) * fz0, rho


def deflection_62(P: Mapping[str, float], s: OperatingState, fx: np.ndarray, fy: np.ndarray,
                  omega: np.ndarray, exact: bool = True) -> Deflection:
    """MF 6.2: solve Fz(Rl) = Fz for the loaded radius with a vectorised secant method.

    Starting guesses 0.95*R0 and R0; converged points are frozen; the better of the two
    previous iterates is kept as the second point (docs/model.md, section 10.3).

    Parameters
    ----------
    exact : bool
        True (default): iterate to |dFz| <= 1e-12*FNOMIN (at most 60 updates), i.e. to the
        root at round-off. False: MFeval 4.3's stop rule, |dFz| <= 1e-6*FNOMIN and at most 18
        updates, which leaves Cz off the root by up to ~2e-6 relative.
    """
    r0 = P["UNLOADED_RADIUS"]
    r_omega = free_radius(P, omega)
    target = s.fz_u
    tol = (EXACT_TOLERANCE if exact else SECANT_TOLERANCE) * P["FNOMIN"]
    max_updates = EXACT_MAX_UPDATES if exact else SECANT_MAX_UPDATES
    x0 = np.full(target.shape, 0.95 * r0)
    x1 = np.full(target.shape, r0)
    y0 = _load_62(P, s, fx, fy, omega, r_omega, x0)[0] - target
    y1 = _load_62(P, s, fx, fy, omega, r_omega, x1)[0] - target
    active = np.abs(y1) > tol
    for _ in range(max_updates):
        if not active.any():
            break
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            x = np.where(active, x1 - y1 * (x1 - x0) / (y1 - y0), x1)
            # a secant step that left the physical range (no root: Fx beyond the load, e.g.
            # 1.1 Fz at 9.8 kN) gives inf/NaN here and ends unconverged (Rl_converged False),
            # not a RuntimeWarning on the user's screen
            y = _load_62(P, s, fx, fy, omega, r_omega, x)[0] - target
        keep = active & (np.abs(y1) < np.abs(y0))
        x0 = np.where(keep, x1, x0)
        y0 = np.where(keep, y1, y0)
        x1 = np.where(active, x, x1)
        y1 = np.where(active, y, y1)
        active = active & (np.abs(y) > tol)
    rl = x1
    with np.errstate(invalid="ignore", over="ignore"):
        rho = _load_62(P, s, fx, fy, omega, r_omega, rl)[1]
    rho = np.where(s.fz == 0, 1e-6, rho)
    with np.errstate(divide="ignore"):
        cz = target / rho
    return Deflection(rho=rho, rl=rl, cz=cz, converged=np.abs(y1) <= tol)


def contact_patch(P: Mapping[str, float], s: OperatingState) -> tuple[np.ndarray, np.ndarray]:
    """Contact patch half length a [m] and half width b [m] (paper eqs. 9-10).

    The load is capped where the deflection would reach the rim (plus BOTTOM_OFFST).
    """
    r0 = P["UNLOADED_RADIUS"]
    cz = P["VERTICAL_STIFFNESS"] * (1 + P["PFZ1"] * s.dpi)
    bottom = P["RIM_RADIUS"] + P["BOTTOM_OFFST"]
    fz = np.where(r0 - s.fz_u / cz < bottom, (r0 - bottom) * cz, s.fz_u)
    q = fz / (cz * r0)
    a = r0 * (P["Q_RA2"] * q + P["Q_RA1"] * np.sqrt(q))
    b = P["WIDTH"] * (P["Q_RB2"] * q + P["Q_RB1"] * np.cbrt(q))
    return a, b


@dataclass(frozen=True)
class Structural:
    """MF-Swift overall stiffnesses and relaxation lengths.

    Attributes
    ----------
    cx, cy : ndarray [N/m]   longitudinal and lateral overall tyre stiffness
    sigmax, sigmay : ndarray [m]  relaxation lengths |Kxk/Cx|, |Kya/Cy|
    """

    cx: np.ndarray
    cy: np.ndarray
    sigmax: np.ndarray
    sigmay: np.ndarray


def structural(P: Mapping[str, float], s: OperatingState, kxk: np.ndarray,
               kya: np.ndarray) -> Structural:
    """Overall stiffnesses (paper eqs. 17-19) with load and pressure dependence."""
    dfz, dpi = s.dfz, s.dpi
    cx = (P["LONGITUDINAL_STIFFNESS"] * (1 + P["PCFX1"] * dfz + P["PCFX2"] * dfz ** 2)
          * (1 + P["PCFX3"] * dpi))
    cy = (P["LATERAL_STIFFNESS"] * (1 + P["PCFY1"] * dfz + P["PCFY2"] * dfz ** 2)
          * (1 + P["PCFY3"] * dpi))
    return Structural(cx=cx, cy=cy, sigmax=np.abs(kxk / cx), sigmay=np.abs(kya / cy))
