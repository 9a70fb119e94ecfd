"""Compiled Newton solve of the cornering-stiffness map's inverse (identify.fit.mcmc.reparam).

Every MCMC step inverts the map for each walker's proposal; proposals without a preimage on
the optimum's branch iterate to the cap. In numpy, on arrays of a few rows, every iteration
pays numpy's per-call overhead several times, and the solve costs many times the likelihood;
compiled row by row in numba it costs a small part of it (bench/mcmc_calibration.py times
the chains of the reparametrised Fy0 stage). The arithmetic is the
numpy map's (mcmc_reparam.KyaRidge._kya), which tests/unit/test_fit_mcmc_reparam.py checks this
against entry by entry.

Coefficient order: mcmc_reparam.ALL_NAMES = (PKY1, PKY2, PKY4, PPY1, PPY2, PKY3, PKY5).
"""
from __future__ import annotations

import math

import numba
import numpy as np

# error_model="numpy" as the model's kernels (identify.model.kernel.vector_math): a division by 0
# gives inf and the row is given up, not a ZeroDivisionError in the middle of a chain
_JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")


@numba.njit(**_JIT)
def _values(full, fz, dpi, g, fz0p, lky, out):
    """Kya at the anchors [N/rad] into ``out``, for the full coefficient vector ``full``."""
    for i in range(fz.size):
        a = full[0] * fz0p * lky * (1 + full[3] * dpi[i]) * (1 - full[5] * abs(g[i]))
        b = (full[1] + full[6] * g[i] * g[i]) * (1 + full[4] * dpi[i])
        out[i] = a * math.sin(full[2] * math.atan(fz[i] / fz0p / b))


@numba.njit(**_JIT)
def _jacobian(full, pos, fz, dpi, g, fz0p, lky, jac):
    """d Kya / d (the replaced coefficients, ``pos`` into the full vector) into ``jac``."""
    k1, k2, k4, p1, p2, k3, k5 = full[0], full[1], full[2], full[3], full[4], full[5], full[6]
    base = fz0p * lky
    for i in range(fz.size):
        ag, g2 = abs(g[i]), g[i] * g[i]
        fp, fc = 1 + p1 * dpi[i], 1 - k3 * ag
        a = k1 * base * fp * fc
        b = (k2 + k5 * g2) * (1 + p2 * dpi[i])
        r = fz[i] / fz0p
        u = math.atan(r / b)
        s, co = math.sin(k4 * u), math.cos(k4 * u)
        dk_db = a * co * k4 * (-r / (b * b + r * r))
        for j in range(pos.size):
            c = pos[j]
            if c == 0:
                v = base * fp * fc * s
            elif c == 1:
                v = dk_db * (1 + p2 * dpi[i])
            elif c == 2:
                v = a * co * u
            elif c == 3:
                v = k1 * base * dpi[i] * fc * s
            elif c == 4:
                v = dk_db * (k2 + k5 * g2) * dpi[i]
            elif c == 5:
                v = -k1 * base * fp * ag * s
            else:
                v = dk_db * g2 * (1 + p2 * dpi[i])
            jac[i, j] = v


@numba.njit(**_JIT)
def _residual(full, fz, dpi, g, fz0p, lky, target, sign, work):
    """max |Kya - target| / |target| over the anchors; inf where a sign differs from
    ``sign`` (PKY2, PKY4, then the peak-load factor at each anchor) or a value is not
    finite."""
    if np.sign(full[1]) != sign[0] or np.sign(full[2]) != sign[1]:
        return np.inf
    for i in range(fz.size):
        b = (full[1] + full[6] * g[i] * g[i]) * (1 + full[4] * dpi[i])
        if np.sign(b) != sign[2 + i]:
            return np.inf
    _values(full, fz, dpi, g, fz0p, lky, work)
    worst = 0.0
    for i in range(fz.size):
        e = abs(work[i] - target[i]) / max(abs(target[i]), 1e-300)
        if not math.isfinite(e):
            return np.inf
        worst = max(worst, e)
    return worst


@numba.njit(**_JIT)
def _solve_in_place(m, rhs):
    """Gaussian elimination with partial pivoting: ``rhs`` becomes m^-1 rhs. False when m is
    singular or not finite (``m`` is overwritten)."""
    n = rhs.size
    for c in range(n):
        piv, best = c, abs(m[c, c])
        for r in range(c + 1, n):
            if abs(m[r, c]) > best:
                piv, best = r, abs(m[r, c])
        if not (best > 0) or not math.isfinite(best):
            return False
        if piv != c:
            for k in range(n):
                m[c, k], m[piv, k] = m[piv, k], m[c, k]
            rhs[c], rhs[piv] = rhs[piv], rhs[c]
        for r in range(c + 1, n):
            f = m[r, c] / m[c, c]
            for k in range(c, n):
                m[r, k] -= f * m[c, k]
            rhs[r] -= f * rhs[c]
    for c in range(n - 1, -1, -1):
        acc = rhs[c]
        for k in range(c + 1, n):
            acc -= m[c, k] * rhs[k]
        rhs[c] = acc / m[c, c]
    for c in range(n):
        if not math.isfinite(rhs[c]):
            return False
    return True


@numba.njit(**_JIT)
def newton_rows(p, target, fixed, pos, fz, dpi, g, fz0p, lky, sign, tol, max_iter,
                max_halvings):
    """Rows of the replaced coefficients with Kya(row) = target, from the starts ``p``
    (W, n; solved in place), and each row's relative residual (W,).

    Newton's method with step halving until the residual falls (at most ``max_halvings``);
    a row stops at ``tol``, after ``max_iter`` steps, or when no halving lowers its
    residual."""
    w, n = p.shape
    err = np.empty(w)
    full = fixed.copy()
    trial = fixed.copy()
    val = np.empty(n)
    jac = np.empty((n, n))
    step = np.empty(n)
    for row in range(w):
        for j in range(n):
            full[pos[j]] = p[row, j]
        e0 = _residual(full, fz, dpi, g, fz0p, lky, target[row], sign, val)
        for _ in range(max_iter):
            if e0 <= tol:
                break
            _values(full, fz, dpi, g, fz0p, lky, val)
            _jacobian(full, pos, fz, dpi, g, fz0p, lky, jac)
            for i in range(n):
                step[i] = val[i] - target[row, i]
            if not _solve_in_place(jac, step):
                break
            lam = 1.0
            e1 = np.inf
            for _half in range(max_halvings + 1):
                for k in range(fixed.size):
                    trial[k] = full[k]
                for j in range(n):
                    trial[pos[j]] = full[pos[j]] - lam * step[j]
                e1 = _residual(trial, fz, dpi, g, fz0p, lky, target[row], sign, val)
                if e1 < e0:
                    break
                lam *= 0.5
            if not e1 < e0:
                break
            for j in range(n):
                full[pos[j]] = trial[pos[j]]
            e0 = e1
        for j in range(n):
            p[row, j] = full[pos[j]]
        err[row] = e0
    return p, err
