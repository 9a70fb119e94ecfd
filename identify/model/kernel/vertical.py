"""Compiled kernel, part 4: rolling radius and spin, deflection, loaded radius, vertical
stiffness, contact patch and overall stiffnesses (twins of model.vertical; change together).

The Re/omega fixed point and the MF 6.2 secant iterate each point to its own convergence, as
the numpy path's per-point semantics do. The fixed point runs over a block of points at once
with a mask (so it vectorises); the secant, whose step count varies a lot, runs point by point.
"""
from __future__ import annotations

import math

import numba

from identify.model.kernel import vector_math as km
from identify.model.kernel.state import JIT, LOOP_JIT

RE_TOLERANCE = 1e-9
RE_MAX_ITERATIONS = 100
EXACT_TOLERANCE = 1e-12
EXACT_MAX_UPDATES = 60
MACHINE_EPS = 2.220446049250313e-16


@numba.njit(**JIT)
def re_deflection(c, fz_u, dpi):
    """The load-dependent part R_omega - Re [m] (independent of omega)."""
    fz0 = c.FNOMIN
    cz = c.VERTICAL_STIFFNESS * (1 + c.PFZ1 * dpi)
    return (fz0 / cz) * (c.DREFF * km.atan(c.BREFF * fz_u / fz0) + c.FREFF * fz_u / fz0)


@numba.njit(**JIT)
def free_radius(c, omega):
    """R_omega [m] at spin rate ``omega`` [rad/s]."""
    r0 = c.UNLOADED_RADIUS
    w = omega * r0 / c.LONGVL
    return r0 * (c.Q_RE0 + c.Q_V1 * w * w)


@numba.njit(**LOOP_JIT)
def rolling_radius_block(c, n, defl, kappa_u, vx_u, re, omega, active):
    """Iterate omega = (1 + kappa) Vx / Re for the first ``n`` points of a block until each
    has converged.

    ``defl`` holds re_deflection per point; ``re``, ``omega`` (outputs) and ``active``
    (scratch, float) are block rows.
    """
    r0 = c.UNLOADED_RADIUS
    for i in range(n):
        re[i] = 0.965 * r0
        omega[i] = 0.0
        active[i] = 1.0
    for _ in range(RE_MAX_ITERATIONS):
        still = 0.0
        for i in range(n):
            new_omega = (1 + kappa_u[i]) * vx_u[i] / re[i]
            new_re = free_radius(c, new_omega) - defl[i]
            on = active[i] == 1.0
            change = abs(re[i] - new_re)
            omega[i] = new_omega if on else omega[i]
            re[i] = new_re if on else re[i]
            active[i] = 1.0 if (on & (change > RE_TOLERANCE)) else 0.0
            still += active[i]
        if still == 0.0:
            break


@numba.njit(**JIT)
def deflection_61(c, fx, fy, omega, dpi, fz_low):
    """MF 6.1 closed-form deflection -> (rho [m], Rl [m], Cz [N/m])."""
    r0, fz0, v0 = c.UNLOADED_RADIUS, c.FNOMIN, c.LONGVL
    qfz1 = math.sqrt((c.VERTICAL_STIFFNESS * r0 / fz0) ** 2 - 4 * c.Q_FZ2)
    e = ((1 + c.Q_V2 * (r0 / v0) * abs(omega) - (c.Q_FCX * fx / fz0) ** 2
          - (c.Q_FCY * fy / fz0) ** 2) * (1 + c.PFZ1 * dpi) * fz0)
    arg = qfz1 * qfz1 + 4 * c.Q_FZ2 * fz_low / e
    x = (-qfz1 + math.sqrt(arg)) / (2 * c.Q_FZ2)
    x = math.nan if (c.Q_FZ2 == 0.0) | (e == 0.0) | (arg < 0.0) else x
    rho = x * r0 if x * r0 > 0.0 else 0.0  # noqa: FURB136 (fmax semantics: NaN -> 0)
    r_omega = free_radius(c, omega)
    rl = r_omega - rho if r_omega - rho > 0.0 else 0.0  # noqa: FURB136
    rho = 1e-6 if fz_low == 0.0 else rho
    cz = fz_low / rho if rho != 0.0 else (math.inf if fz_low > 0 else math.nan)
    return rho, rl, cz


@numba.njit(**JIT)
def _load62(c, qfz1, tan_gamma, fx, fy, omega, dpi, gamma, r_omega, rl):
    """MF 6.2 vertical force Fz(Rl) [N] and deflection rho(Rl) [m] at loaded radius ``rl``."""
    r0, fz0 = c.UNLOADED_RADIUS, c.FNOMIN
    ratio = rl / r_omega
    sfyg = (c.Q_FYS1 + c.Q_FYS2 * ratio + c.Q_FYS3 * ratio * ratio) * gamma
    rho_fr = max(r_omega - rl, 0.0)
    rtw = (1.075 - 0.5 * c.ASPECT_RATIO) * c.WIDTH
    den = ((c.Q_CAM1 * r_omega + c.Q_CAM2 * r_omega * r_omega) * gamma) ** 2
    num = ((c.Q_CAM1 * rl + c.Q_CAM2 * rl * rl) * gamma) ** 2 * (rtw / 8) * abs(tan_gamma)
    rho_g = num / den - c.Q_CAM3 * rho_fr * abs(gamma)
    rho_g = 0.0 if (den == 0.0) | math.isnan(rho_g) else rho_g  # 0/0 at gamma = 0 -> 0
    rho = max(rho_fr + rho_g, 1e-12)
    x = rho / r0
    fcorr = ((1 + c.Q_V2 * (r0 / c.LONGVL) * abs(omega) - (c.Q_FCX * fx / fz0) ** 2
              - (x ** c.Q_FCY2 * c.Q_FCY * (fy - sfyg) / fz0) ** 2) * (1 + c.PFZ1 * dpi))
    return fcorr * (qfz1 * x + c.Q_FZ2 * x * x) * fz0, rho


@numba.njit(**JIT)
def deflection_62(c, fx, fy, omega, dpi, gamma, fz, fz_u):
    """MF 6.2: secant solve of Fz(Rl) = Fz -> (rho [m], Rl [m], Cz [N/m], converged).

    The secant of deflection_62 (starting pair 0.95 R0, R0; the better previous iterate kept).
    """
    r0, fz0 = c.UNLOADED_RADIUS, c.FNOMIN
    qfz1 = math.sqrt((c.VERTICAL_STIFFNESS * r0 / fz0) ** 2 - 4 * c.Q_FZ2)
    tan_gamma = math.tan(gamma)
    r_omega = free_radius(c, omega)
    tol = EXACT_TOLERANCE * fz0
    x0, x1 = 0.95 * r0, r0
    y0 = _load62(c, qfz1, tan_gamma, fx, fy, omega, dpi, gamma, r_omega, x0)[0] - fz_u
    y1 = _load62(c, qfz1, tan_gamma, fx, fy, omega, dpi, gamma, r_omega, x1)[0] - fz_u
    if abs(y1) > tol:
        for _ in range(EXACT_MAX_UPDATES):
            x = x1 - y1 * (x1 - x0) / (y1 - y0)
            y = _load62(c, qfz1, tan_gamma, fx, fy, omega, dpi, gamma, r_omega, x)[0] - fz_u
            if abs(y1) < abs(y0):
                x0, y0 = x1, y1
            x1, y1 = x, y
            if not abs(y) > tol:
                break
    rho = _load62(c, qfz1, tan_gamma, fx, fy, omega, dpi, gamma, r_omega, x1)[1]
    rho = 1e-6 if fz == 0.0 else rho
    # a "root" at Rl <= 0 is off the physical branch (the iterates left the root's basin):
    # reported as not converged, so the caller hands the point to the numpy reference
    return rho, x1, fz_u / rho, (abs(y1) <= tol) & (x1 > 0.0)


@numba.njit(**JIT)
def contact_patch(c, fz_u, dpi):
    """Contact patch half length a [m] and half width b [m]."""
    r0 = c.UNLOADED_RADIUS
    czp = c.VERTICAL_STIFFNESS * (1 + c.PFZ1 * dpi)
    bottom = c.RIM_RADIUS + c.BOTTOM_OFFST
    fzc = (r0 - bottom) * czp if r0 - fz_u / czp < bottom else fz_u
    q = fzc / (czp * r0)
    return (r0 * (c.Q_RA2 * q + c.Q_RA1 * math.sqrt(q)),
            c.WIDTH * (c.Q_RB2 * q + c.Q_RB1 * km.pow(q, 1.0 / 3.0)))


@numba.njit(**JIT)
def structural(c, dfz, dpi):
    """Overall longitudinal and lateral stiffness Cx, Cy [N/m]."""
    cx = (c.LONGITUDINAL_STIFFNESS * (1 + c.PCFX1 * dfz + c.PCFX2 * dfz * dfz)
          * (1 + c.PCFX3 * dpi))
    cy = (c.LATERAL_STIFFNESS * (1 + c.PCFY1 * dfz + c.PCFY2 * dfz * dfz)
          * (1 + c.PCFY3 * dpi))
    return cx, cy
