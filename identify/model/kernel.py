"""Fused per-point kernel of the forward model (numba), for speed.

The pure-numpy path in :mod:`identify.model.evaluate` is the reference; this kernel evaluates
the same equations point by point in compiled code (no temporaries, one pass over memory) and
is tested against it to 1e-12 relative. It covers the default solver options (Re iterated per
point, MF 6.2 loaded radius solved to round-off) and every useMode without turn slip.

Each equation below mirrors a numpy function: ``_fx0`` <-> longitudinal.fx0, ``_fy0`` <->
lateral.fy0, and so on; change both together.
"""
from __future__ import annotations

import math
import os
from collections import namedtuple
from typing import Mapping

import numpy as np

try:  # numba is a dependency, but keep the package importable without it
    import numba
    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    numba = None
    HAVE_NUMBA = False

KERNEL_KEYS = (
    "FITTYP", "LONGVL", "VXLOW", "UNLOADED_RADIUS", "WIDTH", "ASPECT_RATIO", "RIM_RADIUS",
    "INFLPRES", "NOMPRES", "FNOMIN", "VERTICAL_STIFFNESS", "BREFF", "DREFF", "FREFF", "Q_RE0",
    "Q_V1", "Q_V2", "Q_FZ2", "Q_FCX", "Q_FCY", "PFZ1", "Q_FCY2", "Q_CAM1", "Q_CAM2", "Q_CAM3",
    "Q_FYS1", "Q_FYS2", "Q_FYS3", "BOTTOM_OFFST", "LONGITUDINAL_STIFFNESS", "LATERAL_STIFFNESS",
    "PCFX1", "PCFX2", "PCFX3", "PCFY1", "PCFY2", "PCFY3", "Q_RA1", "Q_RA2", "Q_RB1", "Q_RB2",
    "PRESMIN", "PRESMAX", "FZMIN", "FZMAX", "KPUMIN", "KPUMAX", "ALPMIN", "ALPMAX", "CAMMIN",
    "CAMMAX", "LFZO", "LCX", "LMUX", "LEX", "LKX", "LHX", "LVX", "LCY", "LMUY", "LEY", "LKY",
    "LHY", "LVY", "LTR", "LRES", "LXAL", "LYKA", "LVYKA", "LS", "LKYC", "LKZC", "LVMX", "LMX",
    "LMY", "PCX1", "PDX1", "PDX2", "PDX3", "PEX1", "PEX2", "PEX3", "PEX4", "PKX1", "PKX2", "PKX3",
    "PHX1", "PHX2", "PVX1", "PVX2", "PPX1", "PPX2", "PPX3", "PPX4", "RBX1", "RBX2", "RBX3", "RCX1",
    "REX1", "REX2", "RHX1", "QSX1", "QSX2", "QSX3", "QSX4", "QSX5", "QSX6", "QSX7", "QSX8", "QSX9",
    "QSX10", "QSX11", "QSX12", "QSX13", "QSX14", "PPMX1", "PCY1", "PDY1", "PDY2", "PDY3", "PEY1",
    "PEY2", "PEY3", "PEY4", "PEY5", "PKY1", "PKY2", "PKY3", "PKY4", "PKY5", "PKY6", "PKY7", "PHY1",
    "PHY2", "PVY1", "PVY2", "PVY3", "PVY4", "PPY1", "PPY2", "PPY3", "PPY4", "PPY5", "RBY1", "RBY2",
    "RBY3", "RBY4", "RCY1", "REY1", "REY2", "RHY1", "RHY2", "RVY1", "RVY2", "RVY3", "RVY4", "RVY5",
    "RVY6", "QSY1", "QSY2", "QSY3", "QSY4", "QSY5", "QSY6", "QSY7", "QSY8", "QBZ1", "QBZ2", "QBZ3",
    "QBZ4", "QBZ5", "QBZ9", "QBZ10", "QCZ1", "QDZ1", "QDZ2", "QDZ3", "QDZ4", "QDZ6", "QDZ7", "QDZ8",
    "QDZ9", "QDZ10", "QDZ11", "QEZ1", "QEZ2", "QEZ3", "QEZ4", "QEZ5", "QHZ1", "QHZ2", "QHZ3",
    "QHZ4", "PPZ1", "PPZ2", "SSZ1", "SSZ2", "SSZ3", "SSZ4",
)
KernelParams = namedtuple("KernelParams", KERNEL_KEYS)

# Column order of the kernel's output matrix.
KERNEL_COLUMNS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz", "Re", "rho", "2a", "t", "mux", "muy",
                  "omega", "Rl", "2b", "Mzr", "Cx", "Cy", "Cz", "Kya", "sigmax", "sigmay", "Kxk",
                  "kappa_out", "alpha_out", "p_used", "phit_out", "Rl_converged")

EPS = 1e-6


def kernel_params(P: Mapping[str, float]) -> KernelParams:
    """Pack the parameters the kernel needs into a namedtuple of floats."""
    return KernelParams(*(float(P[k]) for k in KERNEL_KEYS))


def _jit(fn):
    if not HAVE_NUMBA:  # pragma: no cover
        return fn
    return numba.njit(cache=True, fastmath=False, error_model="numpy", inline="always")(fn)


@_jit
def _sgn1(x):
    return -1.0 if x < 0.0 else 1.0


@_jit
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@_jit
def _cos_atan(x):
    # cos(atan(x)) = 1/sqrt(1 + x^2) exactly; one sqrt instead of two transcendental calls
    return 1.0 / math.sqrt(1.0 + x * x)


@_jit
def _sine(b, c, d, e, x):
    bx = b * x
    return d * math.sin(c * math.atan(bx - e * (bx - math.atan(bx))))


@_jit
def _cosine(b, c, e, x):
    bx = b * x
    return math.cos(c * math.atan(bx - e * (bx - math.atan(bx))))


@_jit
def _fy0(c, fz, dfz, dpi, fz0p, a_star, g, ws, limits, alpha_star, vx_u):
    """Pure Fy0 -> (fy0, muy, kya, shy, svy, by, cy)."""
    kya = (c.PKY1 * fz0p * (1 + c.PPY1 * dpi) * (1 - c.PKY3 * abs(g))
           * math.sin(c.PKY4 * math.atan((fz / fz0p) / ((c.PKY2 + c.PKY5 * g * g)
                                                        * (1 + c.PPY2 * dpi)))) * c.LKY)
    svyg = fz * (c.PVY3 + c.PVY4 * dfz) * g * c.LKYC * c.LMUY
    kyg0 = fz * (c.PKY6 + c.PKY7 * dfz) * (1 + c.PPY5 * dpi) * c.LKYC
    shy = (c.PHY1 + c.PHY2 * dfz) * c.LHY + (kyg0 * g - svyg) / (kya + EPS * _sgn1(kya))
    svy = fz * (c.PVY1 + c.PVY2 * dfz) * c.LVY * c.LMUY + svyg
    shy *= ws
    svy *= ws
    alpha_y = a_star + shy
    cy = c.PCY1 * c.LCY
    muy = ((c.PDY1 + c.PDY2 * dfz) * (1 + c.PPY3 * dpi + c.PPY4 * dpi * dpi)
           * (1 - c.PDY3 * g * g) * c.LMUY)
    dy = muy * fz
    ey = (c.PEY1 + c.PEY2 * dfz) * (1 + c.PEY5 * g * g - (c.PEY3 + c.PEY4 * g)
                                    * _sgn1(alpha_y)) * c.LEY
    if limits and ey > 1.0:
        ey = 1.0
    by = kya / (cy * dy + EPS * _sgn1(dy))
    f = _sine(by, cy, dy, ey, alpha_y) + svy
    if alpha_star and vx_u < 0:
        f = -f
    if fz == 0.0:
        muy = 0.0
    return f, muy, kya, shy, svy, by, cy


@_jit
def _re_deflection(c, fz_u, dpi):
    """The load-dependent part of R_omega - Re [m] (independent of omega)."""
    fz0 = c.FNOMIN
    cz = c.VERTICAL_STIFFNESS * (1 + c.PFZ1 * dpi)
    return (fz0 / cz) * (c.DREFF * math.atan(c.BREFF * fz_u / fz0) + c.FREFF * fz_u / fz0)


@_jit
def _effective_radius(c, deflection, omega):
    r0 = c.UNLOADED_RADIUS
    return r0 * (c.Q_RE0 + c.Q_V1 * (omega * r0 / c.LONGVL) ** 2) - deflection


@_jit
def _load62(c, qfz1, fx, fy, omega, dpi, gamma, r_omega, rl):
    r0, fz0 = c.UNLOADED_RADIUS, c.FNOMIN
    ratio = rl / r_omega
    sfyg = (c.Q_FYS1 + c.Q_FYS2 * ratio + c.Q_FYS3 * ratio * ratio) * gamma
    rho_fr = max(r_omega - rl, 0.0)
    rtw = (1.075 - 0.5 * c.ASPECT_RATIO) * c.WIDTH
    den = ((c.Q_CAM1 * r_omega + c.Q_CAM2 * r_omega * r_omega) * gamma) ** 2
    num = ((c.Q_CAM1 * rl + c.Q_CAM2 * rl * rl) * gamma) ** 2 * (rtw / 8) * abs(math.tan(gamma))
    if den == 0.0:
        rho_g = 0.0  # 0/0 (gamma = 0): MFeval's NaN -> 0
    else:
        rho_g = num / den - c.Q_CAM3 * rho_fr * abs(gamma)
        if rho_g != rho_g:
            rho_g = 0.0
    rho = max(rho_fr + rho_g, 1e-12)
    x = rho / r0
    fcorr = ((1 + c.Q_V2 * (r0 / c.LONGVL) * abs(omega) - (c.Q_FCX * fx / fz0) ** 2
              - (x ** c.Q_FCY2 * c.Q_FCY * (fy - sfyg) / fz0) ** 2) * (1 + c.PFZ1 * dpi))
    return fcorr * (qfz1 * x + c.Q_FZ2 * x * x) * fz0, rho


@_jit
def _point(c, fz_in, kappa_in, alpha_in, gamma_in, vx_u, p_in, phit_in, omega_in, has_omega,
           limits, alpha_star, out):
    pi = math.pi
    # --- pre-processing (state.prepare) ---
    fz_u = fz_in if fz_in > 0.0 or fz_in != fz_in else 0.0
    kappa_u, alpha_u, gamma_u = kappa_in, alpha_in, gamma_in
    fz, kappa, alpha, gamma, p = fz_u, kappa_u, alpha_u, gamma_u, p_in
    ws = 1.0
    kappa_out = kappa_u
    phit = phit_in
    if limits:
        vxlow = c.VXLOW
        phit = phit * math.cos(alpha_u)
        w_lin = 1.0
        if abs(vx_u) <= vxlow:
            w_lin = abs(vx_u) / vxlow
            ws = 1.0 - 0.5 * (1.0 + math.cos(pi * vx_u / vxlow))
        phit *= w_lin
        kappa_out = kappa_u * w_lin
        if vx_u < 0:
            phit = -phit
        speed = abs(vx_u) + abs(math.tan(alpha_u) * vx_u)
        kappa = kappa * w_lin
        if speed < vxlow:
            alpha = alpha * speed / vxlow
        alpha = min(max(alpha, c.ALPMIN), c.ALPMAX)
        gamma = min(max(gamma, c.CAMMIN), c.CAMMAX)
        fz = min(fz, c.FZMAX)
        fz_low = max(fz, c.FZMIN)
        p = min(max(p, c.PRESMIN), c.PRESMAX)
        kappa = min(max(kappa, c.KPUMIN), c.KPUMAX)
    else:
        fz_low = fz
    alpha_out = 0.0 if vx_u == 0.0 else alpha_u
    fz0p = c.LFZO * c.FNOMIN
    dfz = (fz - fz0p) / fz0p
    dpi = (p - c.NOMPRES) / c.NOMPRES
    if alpha_star:
        a_star = math.tan(alpha) * _sgn(vx_u)
        g_star = math.sin(gamma)
    else:
        a_star = alpha
        g_star = gamma
    vcy = math.tan(alpha) * abs(vx_u)
    vc = math.sqrt(vx_u * vx_u + vcy * vcy)
    cos_ap = vx_u / (vc + EPS * _sgn1(vc))

    # --- Fx0 (longitudinal.fx0) ---
    cx = c.PCX1 * c.LCX
    mux = ((c.PDX1 + c.PDX2 * dfz) * (1 + c.PPX3 * dpi + c.PPX4 * dpi * dpi)
           * (1 - c.PDX3 * gamma * gamma) * c.LMUX)
    if fz == 0.0:
        mux = 0.0
    dx = mux * fz
    kxk = (fz * (c.PKX1 + c.PKX2 * dfz) * math.exp(c.PKX3 * dfz)
           * (1 + c.PPX1 * dpi + c.PPX2 * dpi * dpi) * c.LKX)
    bx = kxk / (cx * dx + EPS * _sgn1(dx))
    shx = (c.PHX1 + c.PHX2 * dfz) * c.LHX * ws
    svx = fz * (c.PVX1 + c.PVX2 * dfz) * c.LVX * c.LMUX * ws
    kx = kappa + shx
    ex = (c.PEX1 + c.PEX2 * dfz + c.PEX3 * dfz * dfz) * (1 - c.PEX4 * _sgn(kx)) * c.LEX
    if limits and ex > 1.0:
        ex = 1.0
    fx0 = _sine(bx, cx, dx, ex, kx) + svx
    if vx_u < 0:
        fx0 = -fx0
    # --- Gxa (longitudinal.gx_alpha) ---
    exa = c.REX1 + c.REX2 * dfz
    if limits and exa > 1.0:
        exa = 1.0
    bxa = (c.RBX1 + c.RBX3 * g_star * g_star) * _cos_atan(c.RBX2 * kappa) * c.LXAL
    gxa = (_cosine(bxa, c.RCX1, exa, a_star + c.RHX1) / _cosine(bxa, c.RCX1, exa, c.RHX1))
    fx = gxa * fx0

    # --- Fy0, Fy0(gamma=0), combined Fy (lateral) ---
    fy0, muy, kya, shy, svy, by, cy = _fy0(c, fz, dfz, dpi, fz0p, a_star, g_star, ws, limits,
                                           alpha_star, vx_u)
    fy0z = _fy0(c, fz, dfz, dpi, fz0p, a_star, 0.0, ws, limits, alpha_star, vx_u)[0]
    dvyk = (muy * fz * (c.RVY1 + c.RVY2 * dfz + c.RVY3 * g_star)
            * _cos_atan(c.RVY4 * a_star))
    svyk = dvyk * math.sin(c.RVY5 * math.atan(c.RVY6 * kappa)) * c.LVYKA * ws
    shyk = c.RHY1 + c.RHY2 * dfz
    eyk = c.REY1 + c.REY2 * dfz
    if limits and eyk > 1.0:
        eyk = 1.0
    byk = ((c.RBY1 + c.RBY4 * g_star * g_star) * _cos_atan(c.RBY2 * (a_star - c.RBY3))
           * c.LYKA)
    gyk = _cosine(byk, c.RCY1, eyk, kappa + shyk) / _cosine(byk, c.RCY1, eyk, shyk)
    fy = gyk * fy0 + svyk

    # --- Mz (aligning.mz) ---
    r0 = c.UNLOADED_RADIUS
    if limits:
        fz_m = 0.0 if fz <= 0 else fz_low
    else:
        fz_m = fz
    kya_p = kya + EPS * _sgn1(kya)
    sht = c.QHZ1 + c.QHZ2 * dfz + (c.QHZ3 + c.QHZ4 * dfz) * g_star
    alpha_r = a_star + shy + svy / kya_p
    alpha_t = a_star + sht
    dt = ((c.QDZ1 + c.QDZ2 * dfz) * (1 - c.PPZ1 * dpi)
          * (1 + c.QDZ3 * gamma + c.QDZ4 * gamma * gamma) * fz_m * (r0 / fz0p) * c.LTR)
    bt = ((c.QBZ1 + c.QBZ2 * dfz + c.QBZ3 * dfz * dfz)
          * (1 + c.QBZ4 * gamma + c.QBZ5 * abs(gamma)) * c.LKY / c.LMUY)
    ct = c.QCZ1
    et = ((c.QEZ1 + c.QEZ2 * dfz + c.QEZ3 * dfz * dfz)
          * (1 + (c.QEZ4 + c.QEZ5 * g_star) * (2 / pi) * math.atan(bt * ct * alpha_t)))
    if limits and et > 1.0:
        et = 1.0
    dr = (fz_m * r0 * ((c.QDZ6 + c.QDZ7 * dfz) * c.LRES
                       + ((c.QDZ8 + c.QDZ9 * dfz) * (1 + c.PPZ2 * dpi)
                          + (c.QDZ10 + c.QDZ11 * dfz) * abs(g_star)) * g_star * c.LKZC)
          * c.LMUY * _sgn(vx_u) * math.cos(a_star))
    br = c.QBZ9 * c.LKY / c.LMUY + c.QBZ10 * by * cy
    r2 = (kxk / kya_p) ** 2 * kappa * kappa
    ar_eq = math.atan(math.sqrt(math.tan(alpha_r) ** 2 + r2)) * _sgn(alpha_r)
    at_eq = math.atan(math.sqrt(math.tan(alpha_t) ** 2 + r2)) * _sgn(alpha_t)
    arm = r0 * (c.SSZ1 + c.SSZ2 * (fy / c.FNOMIN) + (c.SSZ3 + c.SSZ4 * dfz) * gamma) * c.LS
    mzr = dr * _cos_atan(br * ar_eq) * ws
    bta = bt * at_eq
    t = dt * math.cos(ct * math.atan(bta - et * (bta - math.atan(bta)))) * cos_ap * c.LFZO * ws
    mz = -t * (gyk * fy0z) + mzr + arm * fx

    # --- Mx, My (moments) ---
    fz0 = c.FNOMIN
    fzx = fz * (fz / c.FZMIN) ** 2 if fz < c.FZMIN else fz
    mx = r0 * c.LMX * (fzx * (c.QSX1 * c.LVMX - c.QSX2 * gamma * (1 + c.PPMX1 * dpi)
                              - c.QSX12 * gamma * abs(gamma) + c.QSX3 * fy / fz0
                              + c.QSX4 * math.cos(c.QSX5 * math.atan((c.QSX6 * fzx / fz0) ** 2))
                              * math.sin(c.QSX7 * gamma + c.QSX8 * math.atan(c.QSX9 * fy / fz0))
                              + c.QSX10 * math.atan(c.QSX11 * fzx / fz0) * gamma)
                       + fy * (c.QSX13 + c.QSX14 * abs(gamma)))
    fzy = fz_u * (fz_u / c.FZMIN) if fz_u < c.FZMIN else fz_u
    v0 = c.LONGVL
    my = (-r0 * fz0 * c.LMY
          * (c.QSY1 + c.QSY2 * fx / fz0 + c.QSY3 * abs(vx_u / v0) + c.QSY4 * (vx_u / v0) ** 4
             + (c.QSY5 + c.QSY6 * fzy / fz0) * gamma * gamma)
          * (fzy / fz0) ** c.QSY7 * (p / c.NOMPRES) ** c.QSY8)
    if vx_u < 0:
        my = -my
    if vx_u == 0.0:
        my = 0.0
    else:
        hi = c.VXLOW / abs(vx_u) - 1
        lo = -1 - c.VXLOW - hi
        if lo <= kappa_u <= hi:
            my = my * math.sin((pi / 2) * (kappa_u + 1) / (hi + 1))
        elif kappa_u < lo:
            my = -my

    # --- Re, omega (vertical.rolling_radius, per point) ---
    re_defl = _re_deflection(c, fz_u, dpi)
    if has_omega:
        omega = omega_in + 2.220446049250313e-16
        re = _effective_radius(c, re_defl, omega)
    else:
        re = 0.965 * r0
        re_old = r0
        omega = 0.0
        for _ in range(100):
            if not abs(re_old - re) > 1e-9:
                break
            re_old = re
            omega = (1 + kappa_u) * vx_u / re_old
            re = _effective_radius(c, re_defl, omega)
    r_omega = r0 * (c.Q_RE0 + c.Q_V1 * (omega * r0 / v0) ** 2)

    # --- deflection, loaded radius, vertical stiffness ---
    qfz1 = math.sqrt((c.VERTICAL_STIFFNESS * r0 / fz0) ** 2 - 4 * c.Q_FZ2)
    converged = True
    if c.FITTYP == 62.0:
        tol = 1e-12 * fz0
        x0, x1 = 0.95 * r0, r0
        y0 = _load62(c, qfz1, fx, fy, omega, dpi, gamma, r_omega, x0)[0] - fz_u
        y1 = _load62(c, qfz1, fx, fy, omega, dpi, gamma, r_omega, x1)[0] - fz_u
        if abs(y1) > tol:
            for _ in range(60):
                x = x1 - y1 * (x1 - x0) / (y1 - y0)
                y = _load62(c, qfz1, fx, fy, omega, dpi, gamma, r_omega, x)[0] - fz_u
                if abs(y1) < abs(y0):
                    x0, y0 = x1, y1
                x1, y1 = x, y
                if not abs(y) > tol:
                    break
        rl = x1
        converged = abs(y1) <= tol
        rho = _load62(c, qfz1, fx, fy, omega, dpi, gamma, r_omega, rl)[1]
        if fz == 0.0:
            rho = 1e-6
        cz = fz_u / rho
    else:
        e = ((1 + c.Q_V2 * (r0 / v0) * abs(omega) - (c.Q_FCX * fx / fz0) ** 2
              - (c.Q_FCY * fy / fz0) ** 2) * (1 + c.PFZ1 * dpi) * fz0)
        if c.Q_FZ2 == 0.0 or e == 0.0:
            x = math.nan
        else:
            arg = qfz1 * qfz1 + 4 * c.Q_FZ2 * fz_low / e
            x = (-qfz1 + math.sqrt(arg)) / (2 * c.Q_FZ2) if arg >= 0 else math.nan
        rho = x * r0 if x * r0 > 0.0 else 0.0  # fmax semantics: NaN -> 0
        rl = r_omega - rho if r_omega - rho > 0.0 else 0.0
        if fz_low == 0.0:
            rho = 1e-6
        cz = fz_low / rho if rho != 0.0 else (math.inf if fz_low > 0 else math.nan)

    # --- contact patch, overall stiffness, relaxation lengths ---
    czp = c.VERTICAL_STIFFNESS * (1 + c.PFZ1 * dpi)
    bottom = c.RIM_RADIUS + c.BOTTOM_OFFST
    fzc = (r0 - bottom) * czp if r0 - fz_u / czp < bottom else fz_u
    q = fzc / (czp * r0)
    a = r0 * (c.Q_RA2 * q + c.Q_RA1 * math.sqrt(q))
    b = c.WIDTH * (c.Q_RB2 * q + c.Q_RB1 * q ** (1.0 / 3.0))
    cxs = (c.LONGITUDINAL_STIFFNESS * (1 + c.PCFX1 * dfz + c.PCFX2 * dfz * dfz)
           * (1 + c.PCFX3 * dpi))
    cys = (c.LATERAL_STIFFNESS * (1 + c.PCFY1 * dfz + c.PCFY2 * dfz * dfz)
           * (1 + c.PCFY3 * dpi))
    if limits:
        muy = abs(muy)
    out[0], out[1], out[2], out[3], out[4], out[5] = fx, fy, fz_u, mx, my, mz
    out[6], out[7], out[8], out[9], out[10], out[11] = re, rho, 2 * a, t, mux, muy
    out[12], out[13], out[14], out[15], out[16], out[17] = omega, rl, 2 * b, mzr, cxs, cys
    out[18], out[19], out[20], out[21], out[22] = cz, kya, abs(kxk / cxs), abs(kya / cys), kxk
    out[23], out[24], out[25], out[26] = kappa_out, alpha_out, p, phit
    out[27] = 1.0 if converged else 0.0


def _evaluate_all(c, fz, kappa, alpha, gamma, vx, p, phit, omega, has_omega, limits, alpha_star,
                  out):
    for i in range(fz.shape[0]):
        _point(c, fz[i], kappa[i], alpha[i], gamma[i], vx[i], p[i], phit[i], omega[i], has_omega,
               limits, alpha_star, out[i])


if HAVE_NUMBA:  # nogil: chunks run truly in parallel on Python threads
    _evaluate_all = numba.njit(cache=True, fastmath=False, error_model="numpy",
                               nogil=True)(_evaluate_all)


def _evaluate_all_threads(c, fz, *arrays_and_flags):
    """Split the points into one contiguous chunk per core and run them on threads."""
    from concurrent.futures import ThreadPoolExecutor

    (kappa, alpha, gamma, vx, p, phit, omega, has_omega, limits, alpha_star, out) = \
        arrays_and_flags
    n_workers = max(1, min(os.cpu_count() or 1, fz.shape[0] // 1000 or 1))
    edges = np.linspace(0, fz.shape[0], n_workers + 1).astype(int)

    def work(k):
        sl = slice(edges[k], edges[k + 1])
        _evaluate_all(c, fz[sl], kappa[sl], alpha[sl], gamma[sl], vx[sl], p[sl], phit[sl],
                      omega[sl], has_omega, limits, alpha_star, out[sl])

    with ThreadPoolExecutor(n_workers) as pool:
        list(pool.map(work, range(n_workers)))


def evaluate_fused(P: Mapping[str, float], fz, kappa, alpha, gamma, vx, p=None, omega=None,
                   phit=None, mode: int = 111, threads: bool = False) -> dict[str, np.ndarray]:
    """Fused-kernel twin of :func:`identify.model.evaluate.evaluate` (default solver options).

    Same arguments and the same returned dict of arrays. ``threads=True`` spreads the points
    over numba's thread pool (NUMBA_NUM_THREADS cores); points are independent, so the result
    is identical.
    """
    from identify.model.modes import UseMode

    um = mode if isinstance(mode, UseMode) else UseMode.from_code(mode)
    if int(P["FITTYP"]) not in (61, 62):
        raise ValueError(f"FITTYP {int(P['FITTYP'])} is not supported (61 or 62)")
    fz = np.ascontiguousarray(np.atleast_1d(np.asarray(fz, dtype=float)).ravel())
    n = fz.size

    def col(x, default):
        if x is None:
            return np.full(n, default)
        a = np.asarray(x, dtype=float)
        return np.ascontiguousarray(np.broadcast_to(a, (n,)) if a.ndim == 0 else a.ravel())

    p_arr = col(p, 0.0)
    if p is None or np.sum(p_arr) == 0:
        p_arr = np.full(n, float(P["INFLPRES"]))
    om = col(omega, 0.0)
    has_omega = omega is not None and np.sum(om) != 0
    out = np.empty((n, len(KERNEL_COLUMNS)))
    run = _evaluate_all_threads if threads else _evaluate_all
    run(kernel_params(P), fz, col(kappa, 0.0), col(alpha, 0.0), col(gamma, 0.0),
                  col(vx, 0.0), p_arr, col(phit, 0.0), om, has_omega, um.limits, um.alpha_star,
                  out)
    result = {name: out[:, j] for j, name in enumerate(KERNEL_COLUMNS)}
    result["Rl_converged"] = result["Rl_converged"] == 1.0
    return result


def evaluate_fused_frame(P: Mapping[str, float], points, mode: int = 111):
    """Fused-kernel twin of :func:`identify.model.evaluate.evaluate_frame`."""
    from identify.model.evaluate import frame_inputs, output_frame

    return output_frame(points, evaluate_fused(P, **frame_inputs(points), mode=mode))
