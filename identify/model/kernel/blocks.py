"""Compiled kernel, part 5: the loops over points.

``full_block`` computes every output, a block of :data:`BLOCK` points at a time in three
passes: (1) pre-processing, forces, moments, contact patch and stiffnesses, all branch-free so
the loop vectorises; (2) Re and omega (given omega, or the fixed point iterated per point with
a mask); (3) deflection, loaded radius and vertical stiffness. ``forces_block`` computes only
Fx, Fy, or the slip forces with Mz, for fits.
"""
from __future__ import annotations

import numba
import numpy as np

from identify.model.kernel import vertical as kv
from identify.model.kernel.forces import fx0, fy0, fy_combined, gx_alpha
from identify.model.kernel.moments import mx, my, mz
from identify.model.kernel.state import LOOP_JIT, prepare

BLOCK = 512
"""Points per block: a block's scratch columns stay in L1/L2 cache between passes."""

# rows of full_block's output (kernel.KERNEL_COLUMNS)
FX, FY, FZ, MX, MY, MZ, RE, RHO, A2, T, MUX, MUY, OMEGA, RL, B2, MZR, CX, CY, CZ, KYA, \
    SIGMAX, SIGMAY, KXK, KAPPA_OUT, ALPHA_OUT, P_USED, PHIT_OUT, RL_CONVERGED = range(28)
NOUT = 28
SCRATCH = NOUT
"""Block rows after the outputs: SCRATCH + 0 Re deflection term, 1 dpi, 2 limited Fz,
3 limited gamma, 4 Fz_low, 5 fixed-point mask."""
NROWS = SCRATCH + 6


@numba.njit(inline="always")
def _slip_forces(c, s, limits, alpha_star):
    """Combined-slip Fx and Fy and the aligning moment at one prepared point ``s``: (pure
    longitudinal, pure lateral, aligning moment results, Fx, Fy)."""
    lon = fx0(c, s, limits)
    fx = gx_alpha(c, s, limits) * lon.fx0
    lat = fy0(c, s, s.g_star, limits, alpha_star)
    fy0_zero = fy0(c, s, 0.0, limits, alpha_star).fy0
    fy, gyk = fy_combined(c, s, lat.muy, lat.fy0, limits)
    al = mz(c, s, lat, fy0_zero, gyk, fy, fx, lon.kxk, limits)
    return lon, lat, al, fx, fy


@numba.njit(**LOOP_JIT)
def _slip_pass(c, inp, m, limits, alpha_star, blk):
    """Pass 1 over a block's first ``m`` points: everything but Re, omega and the deflection.

    ``inp`` holds rows fz, kappa, alpha, gamma, vx, p, phit, omega of BLOCK values each;
    ``blk`` the NROWS rows of outputs and scratch.
    """
    for i in range(m):
        s = prepare(c, inp[i], inp[BLOCK + i], inp[2 * BLOCK + i], inp[3 * BLOCK + i],
                    inp[4 * BLOCK + i], inp[5 * BLOCK + i], inp[6 * BLOCK + i], limits,
                    alpha_star)
        lon, lat, al, fx, fy = _slip_forces(c, s, limits, alpha_star)
        a, b = kv.contact_patch(c, s.fz_u, s.dpi)
        cx, cy = kv.structural(c, s.dfz, s.dpi)
        blk[FX * BLOCK + i] = fx
        blk[FY * BLOCK + i] = fy
        blk[FZ * BLOCK + i] = s.fz_u
        blk[MX * BLOCK + i] = mx(c, s, fy)
        blk[MY * BLOCK + i] = my(c, s, fx)
        blk[MZ * BLOCK + i] = al.mz
        blk[A2 * BLOCK + i] = 2 * a
        blk[T * BLOCK + i] = al.t
        blk[MUX * BLOCK + i] = lon.mux
        blk[MUY * BLOCK + i] = abs(lat.muy) if limits else lat.muy
        blk[B2 * BLOCK + i] = 2 * b
        blk[MZR * BLOCK + i] = al.mzr
        blk[CX * BLOCK + i] = cx
        blk[CY * BLOCK + i] = cy
        blk[KYA * BLOCK + i] = lat.kya
        blk[SIGMAX * BLOCK + i] = abs(lon.kxk / cx)
        blk[SIGMAY * BLOCK + i] = abs(lat.kya / cy)
        blk[KXK * BLOCK + i] = lon.kxk
        blk[KAPPA_OUT * BLOCK + i] = s.kappa_out
        blk[ALPHA_OUT * BLOCK + i] = s.alpha_out
        blk[P_USED * BLOCK + i] = s.p
        blk[PHIT_OUT * BLOCK + i] = s.phit
        blk[(SCRATCH + 0) * BLOCK + i] = kv.re_deflection(c, s.fz_u, s.dpi)
        blk[(SCRATCH + 1) * BLOCK + i] = s.dpi
        blk[(SCRATCH + 2) * BLOCK + i] = s.fz
        blk[(SCRATCH + 3) * BLOCK + i] = s.gamma
        blk[(SCRATCH + 4) * BLOCK + i] = s.fz_low


@numba.njit(**LOOP_JIT)
def _vertical_pass(c, inp, m, has_omega, blk):
    """Passes 2 and 3 over a block's first ``m`` points: Re and omega, then rho, Rl, Cz."""
    if has_omega:
        for i in range(m):
            w = inp[7 * BLOCK + i] + kv.MACHINE_EPS
            blk[OMEGA * BLOCK + i] = w
            blk[RE * BLOCK + i] = kv.free_radius(c, w) - blk[(SCRATCH + 0) * BLOCK + i]
    else:
        kv.rolling_radius_block(c, m, blk[SCRATCH * BLOCK:], inp[BLOCK:], inp[4 * BLOCK:],
                                blk[RE * BLOCK:], blk[OMEGA * BLOCK:],
                                blk[(SCRATCH + 5) * BLOCK:])
    if c.FITTYP == 62.0:
        for i in range(m):
            rho, rl, cz, ok = kv.deflection_62(
                c, blk[FX * BLOCK + i], blk[FY * BLOCK + i], blk[OMEGA * BLOCK + i],
                blk[(SCRATCH + 1) * BLOCK + i], blk[(SCRATCH + 3) * BLOCK + i],
                blk[(SCRATCH + 2) * BLOCK + i], blk[FZ * BLOCK + i])
            blk[RHO * BLOCK + i] = rho
            blk[RL * BLOCK + i] = rl
            blk[CZ * BLOCK + i] = cz
            blk[RL_CONVERGED * BLOCK + i] = 1.0 if ok else 0.0
    else:
        for i in range(m):
            rho, rl, cz = kv.deflection_61(
                c, blk[FX * BLOCK + i], blk[FY * BLOCK + i], blk[OMEGA * BLOCK + i],
                blk[(SCRATCH + 1) * BLOCK + i], blk[(SCRATCH + 4) * BLOCK + i])
            blk[RHO * BLOCK + i] = rho
            blk[RL * BLOCK + i] = rl
            blk[CZ * BLOCK + i] = cz
            blk[RL_CONVERGED * BLOCK + i] = 1.0


@numba.njit(inline="always")
def _load_slip_inputs(inp, lo, m, fz, kappa, alpha, gamma, vx, p):
    """Copy points ``lo .. lo + m`` of the six slip inputs to rows 0-5 of the flat block
    ``inp`` (see :func:`full_block` for why the block is flat)."""
    for i in range(m):
        inp[i] = fz[lo + i]
        inp[BLOCK + i] = kappa[lo + i]
        inp[2 * BLOCK + i] = alpha[lo + i]
        inp[3 * BLOCK + i] = gamma[lo + i]
        inp[4 * BLOCK + i] = vx[lo + i]
        inp[5 * BLOCK + i] = p[lo + i]


@numba.njit(inline="always")
def _store_rows(blk, rows, lo, m, out):
    """Copy the first ``rows`` rows of the flat block ``blk`` to columns ``lo .. lo + m`` of
    ``out``."""
    for r in range(rows):
        for i in range(m):
            out[r, lo + i] = blk[r * BLOCK + i]


@numba.njit(**LOOP_JIT)
def full_block(c, fz, kappa, alpha, gamma, vx, p, phit, omega, has_omega, limits, alpha_star,
               out):
    """Every output (rows of kernel.KERNEL_COLUMNS) at every point; ``out`` is (28, n).

    Each block's inputs are copied to a flat block array first and its outputs go to another:
    loops over ``range(m)`` with unit stride and compile-time row offsets are what LLVM
    vectorises (an offset index needs a wraparound check, and rows of separate arrays, or
    rows a run-time stride apart, need more overlap checks than the vectoriser will emit).
    """
    n = fz.shape[0]
    inp = np.empty(8 * BLOCK)
    blk = np.empty(NROWS * BLOCK)
    for lo in range(0, n, BLOCK):
        m = min(BLOCK, n - lo)
        _load_slip_inputs(inp, lo, m, fz, kappa, alpha, gamma, vx, p)
        for i in range(m):
            inp[6 * BLOCK + i] = phit[lo + i]
            inp[7 * BLOCK + i] = omega[lo + i]
        _slip_pass(c, inp, m, limits, alpha_star, blk)
        _vertical_pass(c, inp, m, has_omega, blk)
        _store_rows(blk, NOUT, lo, m, out)


@numba.njit(**LOOP_JIT)
def forces_block(c, fz, kappa, alpha, gamma, vx, p, limits, alpha_star, what, out):
    """Slip forces only. ``what`` 0: out[0] = Fx; 1: out[0] = Fy; 2: rows Fx, Fy, Mz, t, Mzr,
    Kya, Kxk, mux, muy (kernel.FORCE_COLUMNS)."""
    n = fz.shape[0]
    if what == 0:
        for i in range(n):
            s = prepare(c, fz[i], kappa[i], alpha[i], gamma[i], vx[i], p[i], 0.0, limits,
                        alpha_star)
            out[0, i] = gx_alpha(c, s, limits) * fx0(c, s, limits).fx0
    elif what == 1:
        for i in range(n):
            s = prepare(c, fz[i], kappa[i], alpha[i], gamma[i], vx[i], p[i], 0.0, limits,
                        alpha_star)
            lat = fy0(c, s, s.g_star, limits, alpha_star)
            out[0, i] = fy_combined(c, s, lat.muy, lat.fy0, limits)[0]
    else:
        _forces_with_mz(c, fz, kappa, alpha, gamma, vx, p, limits, alpha_star, out)


@numba.njit(**LOOP_JIT)
def _forces_with_mz(c, fz, kappa, alpha, gamma, vx, p, limits, alpha_star, out):
    """Rows Fx, Fy, Mz, t, Mzr, Kya, Kxk, mux, muy, a block at a time (as full_block)."""
    n = fz.shape[0]
    inp = np.empty(6 * BLOCK)
    blk = np.empty(9 * BLOCK)
    for lo in range(0, n, BLOCK):
        m = min(BLOCK, n - lo)
        _load_slip_inputs(inp, lo, m, fz, kappa, alpha, gamma, vx, p)
        for i in range(m):
            s = prepare(c, inp[i], inp[BLOCK + i], inp[2 * BLOCK + i], inp[3 * BLOCK + i],
                        inp[4 * BLOCK + i], inp[5 * BLOCK + i], 0.0, limits, alpha_star)
            lon, lat, al, fx, fy = _slip_forces(c, s, limits, alpha_star)
            blk[i] = fx
            blk[BLOCK + i] = fy
            blk[2 * BLOCK + i] = al.mz
            blk[3 * BLOCK + i] = al.t
            blk[4 * BLOCK + i] = al.mzr
            blk[5 * BLOCK + i] = lat.kya
            blk[6 * BLOCK + i] = lon.kxk
            blk[7 * BLOCK + i] = lon.mux
            blk[8 * BLOCK + i] = abs(lat.muy) if limits else lat.muy
        _store_rows(blk, 9, lo, m, out)
