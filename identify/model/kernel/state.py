"""Compiled kernel, part 1: parameters and the per-point pre-processing (twin of model.state).

Everything here is branch-free (selects, min/max) so that the loops in
:mod:`identify.model.kernel.fused` vectorise; the useMode flags are passed as values and applied
with selects, which costs a few wasted operations and keeps one compiled loop for every mode.
"""
from __future__ import annotations

import math
from collections import namedtuple
from collections.abc import Mapping

import numba

from identify.model.kernel import vector_math as km

JIT = {"cache": True, "fastmath": False, "error_model": "numpy", "nogil": True,
       "inline": "always"}
"""Per-point functions: inlined into the loops at numba level (LLVM's own inliner gives up on
functions this size, and a call inside a loop stops vectorisation)."""
LOOP_JIT = {"cache": True, "fastmath": False, "error_model": "numpy", "nogil": True}
"""Functions with loops over points."""
EPS = 1e-6

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

Point = namedtuple("Point", (
    "fz_u", "kappa_u", "alpha_u", "vx_u",   # unmodified inputs (fz_u after the negative clip)
    "fz", "kappa", "alpha", "gamma", "p",   # limited values
    "fz_low", "ws", "dfz", "dpi", "fz0p",   # max(Fz, FZMIN), low-speed factor, increments
    "a_star", "g_star", "cos_ap",           # alpha*, gamma*, cos(alpha')
    "kappa_out", "alpha_out", "phit",       # exported inputs
))
"""One operating point after pre-processing: the fields of model.state.OperatingState."""


def kernel_params(P: Mapping[str, float]) -> KernelParams:
    """Pack the parameters the kernel needs into a namedtuple of floats."""
    return KernelParams(*(float(P[k]) for k in KERNEL_KEYS))


@numba.njit(**JIT)
def sgn1(x):
    """Sign with sgn1(0) = +1."""
    return -1.0 if x < 0.0 else 1.0


@numba.njit(**JIT)
def sgn(x):
    """Sign with sgn(0) = 0 (NaN -> 0)."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@numba.njit(**JIT)
def clip(x, lo, hi):
    """min(max(x, lo), hi) that keeps NaN (as np.clip)."""
    y = lo if x < lo else x  # noqa: FURB136 (a select that keeps NaN, as np.clip)
    return hi if y > hi else y  # noqa: FURB136


@numba.njit(**JIT)
def prepare(c, fz_in, kappa_in, alpha_in, gamma_in, vx_u, p_in, phit_in, limits, alpha_star):
    """MFeval's pre-processing of one point (model.state.prepare) -> :data:`Point`.

    ``limits`` and ``alpha_star`` are the useMode digits (bool); both branches are computed and
    selected.
    """
    fz_u = 0.0 if fz_in < 0.0 else fz_in  # noqa: FURB136 (NaN stays NaN)
    vxlow = c.VXLOW
    avx = abs(vx_u)
    low = avx <= vxlow
    w_lin = avx / vxlow if low else 1.0
    ws_low = 1.0 - 0.5 * (1.0 + km.cos(math.pi * vx_u / vxlow))
    ws = ws_low if (low & limits) else 1.0
    tan_u = km.tan(alpha_in)
    phit_l = phit_in * km.cos(alpha_in) * w_lin
    phit_l = -phit_l if vx_u < 0.0 else phit_l
    speed = avx + abs(tan_u * vx_u)
    alpha_l = alpha_in * speed / vxlow if speed < vxlow else alpha_in
    fz_l = fz_u if fz_u < c.FZMAX else c.FZMAX  # noqa: FURB136 (selects keep NaN)
    fz_low_l = c.FZMIN if fz_l < c.FZMIN else fz_l  # noqa: FURB136
    fz = fz_l if limits else fz_u
    kappa = clip(kappa_in * w_lin, c.KPUMIN, c.KPUMAX) if limits else kappa_in
    alpha = clip(alpha_l, c.ALPMIN, c.ALPMAX) if limits else alpha_in
    gamma = clip(gamma_in, c.CAMMIN, c.CAMMAX) if limits else gamma_in
    p = clip(p_in, c.PRESMIN, c.PRESMAX) if limits else p_in
    fz0p = c.LFZO * c.FNOMIN
    tan_a = km.tan(alpha)
    a_star = tan_a * sgn(vx_u) if alpha_star else alpha
    g_star = km.sin(gamma) if alpha_star else gamma
    vcy = tan_a * avx
    vc = math.sqrt(vx_u * vx_u + vcy * vcy)
    fz_low = fz_low_l if limits else fz_u
    dfz = (fz - fz0p) / fz0p
    dpi = (p - c.NOMPRES) / c.NOMPRES
    cos_ap = vx_u / (vc + EPS * sgn1(vc))
    kappa_out = kappa_in * w_lin if limits else kappa_in
    alpha_out = 0.0 if vx_u == 0.0 else alpha_in
    phit = phit_l if limits else phit_in
    return Point(fz_u, kappa_in, alpha_in, vx_u, fz, kappa, alpha, gamma, p, fz_low, ws, dfz,
                 dpi, fz0p, a_star, g_star, cos_ap, kappa_out, alpha_out, phit)
