"""Compiled kernel, part 3: aligning moment Mz, overturning Mx and rolling resistance My.

Per point and branch-free; twins of aligning.mz, moments.mx and moments.my (change together).
``s`` is a :data:`identify.model.kernel.state.Point`.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numba

from identify.model.kernel import vector_math as km
from identify.model.kernel.forces import shape
from identify.model.kernel.state import EPS, JIT, sgn, sgn1

Aligning = namedtuple("Aligning", ("mz", "t", "mzr"))


@numba.njit(**JIT)
def mz(c, s, lat, fy0_zero_camber, gyk, fy, fx, kxk, limits):
    """Combined aligning moment -> Aligning(mz [N m], t [m], mzr [N m]).

    ``lat`` is the PureLateral at the actual camber; ``fy0_zero_camber`` [N] Fy0 at gamma = 0.
    """
    dfz, dpi, g, a, gamma = s.dfz, s.dpi, s.g_star, s.a_star, s.gamma
    r0, fz0p = c.UNLOADED_RADIUS, s.fz0p
    fz_m = (0.0 if s.fz <= 0.0 else s.fz_low) if limits else s.fz
    kya_p = lat.kya + EPS * sgn1(lat.kya)
    sht = c.QHZ1 + c.QHZ2 * dfz + (c.QHZ3 + c.QHZ4 * dfz) * g
    alpha_r = a + lat.shy + lat.svy / kya_p
    alpha_t = a + sht
    dt = ((c.QDZ1 + c.QDZ2 * dfz) * (1 - c.PPZ1 * dpi)
          * (1 + c.QDZ3 * gamma + c.QDZ4 * gamma * gamma) * fz_m * (r0 / fz0p) * c.LTR)
    bt = ((c.QBZ1 + c.QBZ2 * dfz + c.QBZ3 * dfz * dfz)
          * (1 + c.QBZ4 * gamma + c.QBZ5 * abs(gamma)) * c.LKY / c.LMUY)
    ct = c.QCZ1
    et = ((c.QEZ1 + c.QEZ2 * dfz + c.QEZ3 * dfz * dfz)
          * (1 + (c.QEZ4 + c.QEZ5 * g) * (2 / math.pi) * km.atan(bt * ct * alpha_t)))
    et = min(et, 1.0) if limits else et
    dr = (fz_m * r0 * ((c.QDZ6 + c.QDZ7 * dfz) * c.LRES
                       + ((c.QDZ8 + c.QDZ9 * dfz) * (1 + c.PPZ2 * dpi)
                          + (c.QDZ10 + c.QDZ11 * dfz) * abs(g)) * g * c.LKZC)
          * c.LMUY * sgn(s.vx_u) * km.cos(a))
    br = c.QBZ9 * c.LKY / c.LMUY + c.QBZ10 * lat.by * lat.cy
    r2 = (kxk / kya_p) ** 2 * s.kappa * s.kappa
    tr = km.tan(alpha_r)
    tt = km.tan(alpha_t)
    ar_eq = km.atan(math.sqrt(tr * tr + r2)) * sgn(alpha_r)
    at_eq = km.atan(math.sqrt(tt * tt + r2)) * sgn(alpha_t)
    arm = r0 * (c.SSZ1 + c.SSZ2 * (fy / c.FNOMIN) + (c.SSZ3 + c.SSZ4 * dfz) * gamma) * c.LS
    mzr = dr / km.sqrt1p2(br * ar_eq) * s.ws
    t = dt * km.cos(shape(bt * at_eq, ct, et, 1.0)) * s.cos_ap * c.LFZO * s.ws
    return Aligning(-t * (gyk * fy0_zero_camber) + mzr + arm * fx, t, mzr)


@numba.njit(**JIT)
def mx(c, s, fy):
    """Overturning moment Mx [N m] from the combined lateral force ``fy`` [N]."""
    fz0, gamma, fz = c.FNOMIN, s.gamma, s.fz
    ratio = fz / c.FZMIN
    fzx = fz * ratio * ratio if fz < c.FZMIN else fz
    return c.UNLOADED_RADIUS * c.LMX * (
        fzx * (c.QSX1 * c.LVMX - c.QSX2 * gamma * (1 + c.PPMX1 * s.dpi)
               - c.QSX12 * gamma * abs(gamma) + c.QSX3 * fy / fz0
               + c.QSX4 * km.cos(c.QSX5 * km.atan((c.QSX6 * fzx / fz0) ** 2))
               * km.sin(c.QSX7 * gamma + c.QSX8 * km.atan(c.QSX9 * fy / fz0))
               + c.QSX10 * km.atan(c.QSX11 * fzx / fz0) * gamma)
        + fy * (c.QSX13 + c.QSX14 * abs(gamma)))


@numba.njit(**JIT)
def my(c, s, fx):
    """Rolling-resistance moment My [N m] from the combined longitudinal force ``fx`` [N]."""
    fz0, v0, vx, fz_u = c.FNOMIN, c.LONGVL, s.vx_u, s.fz_u
    fzy = fz_u * (fz_u / c.FZMIN) if fz_u < c.FZMIN else fz_u
    ratio_v = vx / v0
    rv2 = ratio_v * ratio_v
    out = (-c.UNLOADED_RADIUS * fz0 * c.LMY
           * (c.QSY1 + c.QSY2 * fx / fz0 + c.QSY3 * abs(ratio_v) + c.QSY4 * rv2 * rv2
              + (c.QSY5 + c.QSY6 * fzy / fz0) * s.gamma * s.gamma)
           * km.pow(fzy / fz0, c.QSY7) * km.pow(s.p / c.NOMPRES, c.QSY8))
    out = -out if vx < 0.0 else out
    hi = c.VXLOW / abs(vx) - 1
    lo = -1 - c.VXLOW - hi
    k = s.kappa_u
    shaped = out * km.sin((math.pi / 2) * (k + 1) / (hi + 1))
    out = shaped if ((k >= lo) & (k <= hi)) else out
    out = -out if k < lo else out
    return 0.0 if vx == 0.0 else out
