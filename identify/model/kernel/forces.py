"""Compiled kernel, part 2: Fx0, Fy0 and the combined-slip forces, per point and branch-free.

Each function mirrors a numpy function and must change with it: ``fx0`` <-> longitudinal.fx0,
``gx_alpha`` <-> longitudinal.gx_alpha, ``fy0`` <-> lateral.fy0, ``fy_combined`` <->
lateral.fy_combined. ``s`` is a :data:`identify.model.kernel.state.Point`.
"""
from __future__ import annotations

from collections import namedtuple

import numba

from identify.model.kernel import vector_math as km
from identify.model.kernel.state import EPS, JIT, sgn, sgn1

PureLateral = namedtuple("PureLateral", ("fy0", "muy", "kya", "shy", "svy", "by", "cy"))
PureLongitudinal = namedtuple("PureLongitudinal", ("fx0", "mux", "kxk"))


@numba.njit(**JIT)
def shape(b, c, e, x):
    """C*atan(B*x - E*(B*x - atan(B*x))): the Magic Formula's phase."""
    bx = b * x
    return c * km.atan(bx - e * (bx - km.atan(bx)))


@numba.njit(**JIT)
def fx0(c, s, limits):
    """Pure longitudinal slip force -> PureLongitudinal(fx0 [N], mux [-], kxk [N])."""
    dfz, dpi, fz = s.dfz, s.dpi, s.fz
    cx = c.PCX1 * c.LCX
    mux = ((c.PDX1 + c.PDX2 * dfz) * (1 + c.PPX3 * dpi + c.PPX4 * dpi * dpi)
           * (1 - c.PDX3 * s.gamma * s.gamma) * c.LMUX)
    mux = 0.0 if fz == 0.0 else mux
    dx = mux * fz
    kxk = (fz * (c.PKX1 + c.PKX2 * dfz) * km.exp(c.PKX3 * dfz)
           * (1 + c.PPX1 * dpi + c.PPX2 * dpi * dpi) * c.LKX)
    bx = kxk / (cx * dx + EPS * sgn1(dx))
    shx = (c.PHX1 + c.PHX2 * dfz) * c.LHX * s.ws
    svx = fz * (c.PVX1 + c.PVX2 * dfz) * c.LVX * c.LMUX * s.ws
    kx = s.kappa + shx
    ex = (c.PEX1 + c.PEX2 * dfz + c.PEX3 * dfz * dfz) * (1 - c.PEX4 * sgn(kx)) * c.LEX
    ex = min(ex, 1.0) if limits else ex
    f = dx * km.sin(shape(bx, cx, ex, kx)) + svx
    return PureLongitudinal(-f if s.vx_u < 0.0 else f, mux, kxk)


@numba.njit(**JIT)
def gx_alpha(c, s, limits):
    """Combined-slip weighting G_x,alpha [-]."""
    exa = c.REX1 + c.REX2 * s.dfz
    exa = min(exa, 1.0) if limits else exa
    bxa = ((c.RBX1 + c.RBX3 * s.g_star * s.g_star) / km.sqrt1p2(c.RBX2 * s.kappa) * c.LXAL)
    return (km.cos(shape(bxa, c.RCX1, exa, s.a_star + c.RHX1))
            / km.cos(shape(bxa, c.RCX1, exa, c.RHX1)))


@numba.njit(**JIT)
def fy0(c, s, g, limits, alpha_star):
    """Pure side-slip force at camber ``g`` (gamma*, or 0.0 for Fy0 at zero camber)."""
    dfz, dpi, fz, fz0p = s.dfz, s.dpi, s.fz, s.fz0p
    kya = (c.PKY1 * fz0p * (1 + c.PPY1 * dpi) * (1 - c.PKY3 * abs(g))
           * km.sin(c.PKY4 * km.atan((fz / fz0p) / ((c.PKY2 + c.PKY5 * g * g)
                                                    * (1 + c.PPY2 * dpi)))) * c.LKY)
    svyg = fz * (c.PVY3 + c.PVY4 * dfz) * g * c.LKYC * c.LMUY
    kyg0 = fz * (c.PKY6 + c.PKY7 * dfz) * (1 + c.PPY5 * dpi) * c.LKYC
    shy = ((c.PHY1 + c.PHY2 * dfz) * c.LHY + (kyg0 * g - svyg) / (kya + EPS * sgn1(kya))) * s.ws
    svy = (fz * (c.PVY1 + c.PVY2 * dfz) * c.LVY * c.LMUY + svyg) * s.ws
    alpha_y = s.a_star + shy
    cy = c.PCY1 * c.LCY
    muy = ((c.PDY1 + c.PDY2 * dfz) * (1 + c.PPY3 * dpi + c.PPY4 * dpi * dpi)
           * (1 - c.PDY3 * g * g) * c.LMUY)
    dy = muy * fz
    ey = ((c.PEY1 + c.PEY2 * dfz)
          * (1 + c.PEY5 * g * g - (c.PEY3 + c.PEY4 * g) * sgn1(alpha_y)) * c.LEY)
    ey = min(ey, 1.0) if limits else ey
    by = kya / (cy * dy + EPS * sgn1(dy))
    f = dy * km.sin(shape(by, cy, ey, alpha_y)) + svy
    f = -f if (alpha_star & (s.vx_u < 0.0)) else f
    return PureLateral(f, 0.0 if fz == 0.0 else muy, kya, shy, svy, by, cy)


@numba.njit(**JIT)
def fy_combined(c, s, muy, fy0_value, limits):
    """Combined-slip lateral force -> (fy [N], gyk [-])."""
    dfz, g, a = s.dfz, s.g_star, s.a_star
    dvyk = muy * s.fz * (c.RVY1 + c.RVY2 * dfz + c.RVY3 * g) / km.sqrt1p2(c.RVY4 * a)
    svyk = dvyk * km.sin(c.RVY5 * km.atan(c.RVY6 * s.kappa)) * c.LVYKA * s.ws
    shyk = c.RHY1 + c.RHY2 * dfz
    eyk = c.REY1 + c.REY2 * dfz
    eyk = min(eyk, 1.0) if limits else eyk
    byk = (c.RBY1 + c.RBY4 * g * g) / km.sqrt1p2(c.RBY2 * (a - c.RBY3)) * c.LYKA
    gyk = (km.cos(shape(byk, c.RCY1, eyk, s.kappa + shyk))
           / km.cos(shape(byk, c.RCY1, eyk, shyk)))
    return gyk * fy0_value + svyk, gyk
