"""Reparametrisation of the Fy0 cornering-stiffness ridge for MCMC (issue 17).

The cornering stiffness at zero camber and nominal pressure is

    Kya(Fz) = PKY1 Fz0' LKY sin(PKY4 atan(Fz / (PKY2 Fz0')))        [N/rad]

(Fz0' = LFZO FNOMIN). With trailer loads well below its peak PKY2 Fz0' (the bundled sample:
3, 5 and 7 kN against 13 kN) the data see only the nearly straight start of this curve and
PKY1, PKY2, PKY4 lie on a thin curved ridge: emcee's affine-invariant moves follow a straight
ridge at no cost but a curved one slowly (tau ~ 1700 steps on the sample). The data measure
Kya at their load levels, so the chain samples

    z = (Kya(F_lo), Kya(F_mid), Kya(F_hi))

at the 5 %, 50 % and 95 % quantiles of the stage's loads instead of (PKY1, PKY2, PKY4): each
is fixed by the sweeps at one load level, so the posterior in z is close to an uncorrelated
Gaussian. The prior stays flat in (PKY1, PKY2, PKY4) within their bounds: the density in z
carries the Jacobian of the inverse map, log |det d(PKY1, PKY2, PKY4)/dz| = -log |det dz/dPKY|
(:meth:`KyaRidge.inverse`). The inverse map is solved by Newton's method for all walkers at
once from the least-squares optimum; the posterior is thereby the flat-prior one restricted to
the branch of solutions connected to the optimum (points whose Newton iteration does not
converge get zero density; tests/test_fit_mcmc.py checks the marginals against the exact
posterior integrated on a grid in PKY space).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

__all__ = ["KyaRidge", "kya_ridge"]

NAMES = ("PKY1", "PKY2", "PKY4")
QUANTILES = (0.05, 0.5, 0.95)
"""Load quantiles at which Kya is sampled."""
NEWTON_ITER = 30
NEWTON_TOL = 1e-11
"""Relative residual |Kya(PKY) - z| / |z| at which the inverse map is accepted."""


@dataclass(frozen=True)
class KyaRidge:
    """The map between (PKY1, PKY2, PKY4) and Kya at three loads.

    Attributes
    ----------
    index : tuple of int     positions of PKY1, PKY2, PKY4 in the problem's free vector
    loads : tuple of float   F_lo, F_mid, F_hi [N]
    fz0p : float             LFZO FNOMIN [N]
    lky : float              LKY [-]
    start : tuple of float   (PKY1, PKY2, PKY4) where Newton's method starts (the optimum)
    """

    index: tuple[int, int, int]
    loads: tuple[float, float, float]
    fz0p: float
    lky: float
    start: tuple[float, float, float]

    @property
    def labels(self) -> tuple[str, ...]:
        """Names of the sampled coordinates, e.g. ``Kya@3000N``."""
        return tuple(f"Kya@{f:.0f}N" for f in self.loads)

    def _kya(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kya at the loads (W, 3) [N/rad] and its Jacobian d Kya / d PKY (W, 3, 3)."""
        p1, p2, p4 = p[:, 0:1], p[:, 1:2], p[:, 2:3]
        f = np.asarray(self.loads)[None, :]
        a = p1 * self.fz0p * self.lky
        c = p2 * self.fz0p
        u = np.arctan(f / c)
        s, co = np.sin(p4 * u), np.cos(p4 * u)
        jac = np.stack([self.fz0p * self.lky * s,
                        a * co * p4 * (-f / (c * c + f * f)) * self.fz0p,
                        a * co * u], axis=-1)
        return a * s, jac

    def forward(self, x: np.ndarray) -> np.ndarray:
        """Free vectors x (W, k) -> sampled vectors z (W, k): PKY1, PKY2, PKY4 replaced by Kya
        at the three loads, in their places."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        z = x.copy()
        z[:, list(self.index)] = self._kya(x[:, list(self.index)])[0]
        return z

    def inverse(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sampled vectors z (W, k) -> free vectors x (W, k) and log |det dx/dz| (W,).

        Newton's method with backtracking on the relative residual for all rows at once (3 x 3
        solves by Cramer's rule), from the map linearised at the optimum (a fixed start, so
        that the map is a function of z alone); rows it does not bring to NEWTON_TOL start
        again from the optimum itself. Rows that do not reach NEWTON_TOL
        (or would change the sign of PKY2 or PKY4 from the optimum's) come back as NaN with
        log-determinant -inf.
        """
        z = np.atleast_2d(np.asarray(z, dtype=float))
        idx = list(self.index)
        target = z[:, idx]
        start = np.asarray(self.start, dtype=float)
        y0, j0 = self._kya(start[None, :])
        linear = start + _solve3(np.broadcast_to(j0, (len(z), 3, 3)), target - y0)
        p, err = self._newton(linear, target)
        again = np.flatnonzero(err > NEWTON_TOL)
        if again.size:
            p[again], err[again] = self._newton(
                np.broadcast_to(start, (again.size, 3)).copy(), target[again])
        ok = err <= NEWTON_TOL
        with np.errstate(all="ignore"):
            logdet = -np.log(np.abs(_det3(self._kya(p)[1])))
        ok &= np.isfinite(logdet)
        x = z.copy()
        x[:, idx] = np.where(ok[:, None], p, np.nan)
        return x, np.where(ok, logdet, -np.inf)

    def _newton(self, p: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(PKY1, PKY2, PKY4) rows with Kya = target from the starts ``p``, and the relative
        residuals (inf where the signs of PKY2, PKY4 differ from the optimum's)."""
        sign = np.sign(np.asarray(self.start, dtype=float)[1:])
        p = p.copy()
        scale = np.maximum(np.abs(target), 1e-300)

        def resid(q, t, s):
            with np.errstate(all="ignore"):
                r = np.max(np.abs(self._kya(q)[0] - t) / s, axis=1)
            return np.where(np.all(q[:, 1:] * sign > 0, axis=1) & np.isfinite(r), r, np.inf)

        err = resid(p, target, scale)
        active = np.flatnonzero(err > NEWTON_TOL)
        for _ in range(NEWTON_ITER):
            if active.size == 0:
                break
            q, t, s = p[active], target[active], scale[active]
            y, jac = self._kya(q)
            step = _solve3(jac, y - t)
            e0 = err[active]
            lam = np.ones(active.size)
            e1 = resid(q - step, t, s)
            worse = np.flatnonzero(~(e1 < e0))
            for _half in range(10):  # backtrack the rows whose residual did not fall
                if worse.size == 0:
                    break
                lam[worse] *= 0.5
                e1[worse] = resid(q[worse] - lam[worse, None] * step[worse], t[worse],
                                  s[worse])
                worse = worse[~(e1[worse] < e0[worse])]
            better = e1 < e0
            q[better] -= lam[better, None] * step[better]
            p[active] = q
            err[active] = np.where(better, e1, e0)
            active = active[better & (err[active] > NEWTON_TOL)]
        return p, err


def _det3(m: np.ndarray) -> np.ndarray:
    """Determinants of (W, 3, 3) matrices."""
    return (m[:, 0, 0] * (m[:, 1, 1] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 1])
            - m[:, 0, 1] * (m[:, 1, 0] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 0])
            + m[:, 0, 2] * (m[:, 1, 0] * m[:, 2, 1] - m[:, 1, 1] * m[:, 2, 0]))


def _solve3(m: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solutions of (W, 3, 3) systems m x = b by Cramer's rule; 0 where m is singular."""
    d = _det3(m)
    out = np.empty_like(b)
    for j in range(3):
        mj = m.copy()
        mj[:, :, j] = b
        with np.errstate(all="ignore"):
            out[:, j] = _det3(mj) / d
    return np.where(np.isfinite(out), out, 0.0)


def kya_ridge(free: Sequence[str], x: np.ndarray, fz: np.ndarray,
              params: Mapping[str, float]) -> KyaRidge | None:
    """The Fy0 ridge map for a problem with free names ``free`` at the optimum ``x``, or None
    when PKY1, PKY2 and PKY4 are not all free or the loads ``fz`` [N] span less than 20 % of
    Fz0' (three distinct levels are needed).

    Parameters
    ----------
    free : sequence of str    the problem's free coefficients
    x : ndarray               their values at the optimum
    fz : ndarray [N]          the stage's vertical loads
    params : mapping          the .tir values (FNOMIN, LFZO, LKY)
    """
    if not set(NAMES) <= set(free):
        return None
    fz0p = float(params.get("LFZO", 1.0)) * float(params["FNOMIN"])
    loads = tuple(float(q) for q in np.quantile(np.abs(np.asarray(fz, dtype=float)), QUANTILES))
    if min(np.diff(loads)) < 0.1 * fz0p:
        return None
    index = tuple(list(free).index(n) for n in NAMES)
    start = tuple(float(x[i]) for i in index)
    if start[1] == 0 or start[2] == 0:
        return None
    return KyaRidge(index=index, loads=loads, fz0p=fz0p, lky=float(params.get("LKY", 1.0)),
                    start=start)
