"""Reparametrisation of the Fy0 cornering-stiffness ridge for MCMC.

The cornering stiffness is (docs/model.md, section 5)

    Kya = PKY1 Fz0' (1 + PPY1 dpi) (1 - PKY3 |g|) LKY
          * sin(PKY4 atan(Fz / (Fz0' (PKY2 + PKY5 g^2) (1 + PPY2 dpi))))     [N/rad]

(Fz0' = LFZO FNOMIN, g = gamma*). With trailer loads well below its peak (the bundled sample:
3, 5 and 7 kN against 13 kN) the data see only the nearly straight start of this curve:
PKY1, PKY2, PKY4 lie on a thin curved ridge, and so do the pressure pair PPY1, PPY2 (below the
peak Kya depends on nearly only (1 + PPY1 dpi) / (1 + PPY2 dpi)) and the camber pair PKY3,
PKY5. emcee's affine-invariant moves follow a straight ridge at no cost but a curved one
slowly, and each pair left in the coefficients keeps its own curved ridge
(bench/mcmc_calibration.py --no-reparam samples the coefficients directly, for
comparison). The data measure
Kya where they were taken, so the chain samples Kya at as many measured conditions
("anchors") as there are such coefficients free, instead of the coefficients:

- Kya at the 5 %, 50 % and 95 % load quantiles, at the reference pressure (of the pressures'
  5 %, 50 % and 95 % quantiles the one nearest nominal: the level nearest nominal when the
  levels hold similar shares of the points) and zero camber, for PKY1, PKY2, PKY4;
- for PPY1 and PPY2 (when free and those pressure quantiles span 5 % of nominal): Kya at the
  lowest and highest load at the 5 % or 95 % pressure quantile farthest from the reference
  (one anchor, the middle load, when only one of the two is free);
- for PKY3 and PKY5 (when free and the 95 % quantile of |gamma*| reaches 0.02): the same at
  that camber.

Each anchor is fixed by the sweeps at one condition, so the posterior in these coordinates is
close to an uncorrelated Gaussian. The prior stays flat in the coefficients within their
bounds: the density in the anchors carries the Jacobian of the inverse map,
log |det dx/dz| = -log |det dz/dx| (:meth:`KyaRidge.inverse`). The inverse map is solved by
Newton's method for all walkers at once from the least-squares optimum; the posterior is
thereby the flat-prior one restricted to the branch of solutions connected to the optimum
(points whose Newton iteration does not converge get zero density;
tests/integration/test_fit_mcmc.py
checks the marginals against the exact posterior integrated on a grid).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from identify.fit.mcmc.kya_newton import newton_rows

__all__ = ["KyaRidge", "kya_ridge"]

NAMES = ("PKY1", "PKY2", "PKY4")
"""The coefficients every reparametrisation replaces (the load ridge)."""
PRESSURE_NAMES = ("PPY1", "PPY2")
CAMBER_NAMES = ("PKY3", "PKY5")
ALL_NAMES = NAMES + PRESSURE_NAMES + CAMBER_NAMES
"""Order of the coefficient vector of KyaRidge's maps."""
QUANTILES = (0.05, 0.5, 0.95)
"""Load quantiles at which Kya is sampled."""
MIN_PRESSURE_SPAN = 0.05
"""Span of dpi (5 % of nominal pressure) below which PPY1, PPY2 are sampled directly."""
MIN_CAMBER = 0.02
"""|gamma*| (95 % quantile) below which PKY3, PKY5 are sampled directly."""
NEWTON_ITER = 30
NEWTON_TOL = 1e-11
"""Relative residual |Kya(x) - z| / |z| at which the inverse map is accepted."""
MAX_HALVINGS = 10
"""Step halvings per Newton step before a row is given up."""


@dataclass(frozen=True)
class KyaRidge:
    """The map between the cornering-stiffness coefficients and Kya at anchor conditions.

    Attributes
    ----------
    index : tuple of int     positions of the replaced coefficients in the free vector
    names : tuple of str     their names (PKY1, PKY2, PKY4 first, then PPY*, PKY3/PKY5)
    anchors : tuple          (Fz [N], dpi [-], gamma* [rad]) per sampled coordinate
    fixed : tuple of float   the seven ALL_NAMES coefficients' values where not replaced
    fz0p : float             LFZO FNOMIN [N]
    lky : float              LKY [-]
    start : tuple of float   the replaced coefficients where Newton's method starts
    labels : tuple of str    names of the sampled coordinates, e.g. ``Kya@3000N``
    """

    index: tuple[int, ...]
    names: tuple[str, ...]
    anchors: tuple[tuple[float, float, float], ...]
    fixed: tuple[float, ...]
    fz0p: float
    lky: float
    start: tuple[float, ...]
    labels: tuple[str, ...]

    @property
    def loads(self) -> tuple[float, float, float]:
        """The three loads of the PKY1, PKY2, PKY4 anchors [N]."""
        return tuple(a[0] for a in self.anchors[:3])

    @property
    def _positions(self) -> np.ndarray:
        """Places of the replaced coefficients in the ALL_NAMES vector."""
        return np.array([ALL_NAMES.index(name) for name in self.names], dtype=np.int64)

    def _full(self, p: np.ndarray) -> np.ndarray:
        """ALL_NAMES vectors (W, 7): ``fixed`` with the rows p (W, n) of the replaced
        coefficients in their places."""
        full = np.tile(np.asarray(self.fixed, dtype=float), (p.shape[0], 1))
        full[:, self._positions] = p
        return full

    def _kya(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kya at the anchors (W, n) [N/rad] and its Jacobian d Kya / d p (W, n, n) for
        rows p (W, n) of the replaced coefficients."""
        w, n = p.shape
        full = self._full(p)
        k1, k2, k4, p1, p2, k3, k5 = (full[:, i:i + 1] for i in range(len(ALL_NAMES)))
        fz, dpi, g = (np.asarray(c, dtype=float)[None, :] for c in zip(*self.anchors))
        ag = np.abs(g)
        base = self.fz0p * self.lky
        a = k1 * base * (1 + p1 * dpi) * (1 - k3 * ag)
        b = (k2 + k5 * g ** 2) * (1 + p2 * dpi)
        r = fz / self.fz0p
        u = np.arctan(r / b)
        s, co = np.sin(k4 * u), np.cos(k4 * u)
        dk_db = a * co * k4 * (-r / (b * b + r * r))
        d = {"PKY1": base * (1 + p1 * dpi) * (1 - k3 * ag) * s,
             "PPY1": k1 * base * dpi * (1 - k3 * ag) * s,
             "PKY3": -k1 * base * (1 + p1 * dpi) * ag * s,
             "PKY4": a * co * u,
             "PKY2": dk_db * (1 + p2 * dpi),
             "PKY5": dk_db * g ** 2 * (1 + p2 * dpi),
             "PPY2": dk_db * (k2 + k5 * g ** 2) * dpi}
        jac = np.stack([np.broadcast_to(d[name], (w, n)) for name in self.names], axis=-1)
        return a * s, jac

    def forward(self, x: np.ndarray) -> np.ndarray:
        """Free vectors x (W, k) -> sampled vectors z (W, k): the replaced coefficients
        replaced by Kya at the anchors, in their places."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        z = x.copy()
        z[:, list(self.index)] = self._kya(x[:, list(self.index)])[0]
        return z

    def inverse(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sampled vectors z (W, k) -> free vectors x (W, k) and log |det dx/dz| (W,).

        Newton's method with backtracking on the relative residual for all rows at once, from
        the map linearised at the optimum (a fixed start, so that the map is a function of z
        alone); rows it does not bring to NEWTON_TOL start again from the optimum itself.
        Rows that do not reach NEWTON_TOL (or would change the sign of PKY2 or PKY4, or of
        the stiffness curve's peak load at an anchor, from the optimum's) come back as NaN
        with log-determinant -inf.
        """
        z = np.atleast_2d(np.asarray(z, dtype=float))
        idx = list(self.index)
        target = z[:, idx]
        start = np.asarray(self.start, dtype=float)
        y0, j0 = self._kya(start[None, :])
        linear = start + _solve(np.broadcast_to(j0, (len(z),) + j0.shape[1:]), target - y0)
        p, err = self._newton(linear, target)
        again = np.flatnonzero(err > NEWTON_TOL)
        if again.size:
            p[again], err[again] = self._newton(
                np.broadcast_to(start, (again.size, start.size)).copy(), target[again])
        ok = err <= NEWTON_TOL
        with np.errstate(all="ignore"):
            logdet = -np.linalg.slogdet(self._kya(p)[1])[1]
        ok &= np.isfinite(logdet)
        x = z.copy()
        x[:, idx] = np.where(ok[:, None], p, np.nan)
        return x, np.where(ok, logdet, -np.inf)

    def _start_signs(self) -> np.ndarray:
        """Signs of PKY2, PKY4 and of the peak-load factor (PKY2 + PKY5 g^2)(1 + PPY2 dpi)
        at every anchor, at the optimum (the branch the inverse keeps)."""
        _, k2, k4, _, p2, _, k5 = self._full(np.asarray(self.start, dtype=float)[None, :])[0]
        _, dpi, g = (np.asarray(c, dtype=float) for c in zip(*self.anchors))
        return np.sign(np.concatenate([[k2, k4], (k2 + k5 * g ** 2) * (1 + p2 * dpi)]))

    def _newton(self, p: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coefficient rows with Kya = target from the starts ``p``, and the relative residuals
        (inf where the signs of PKY2, PKY4 or a peak load differ from the optimum's), row by
        row in compiled code (identify.fit.mcmc.kya_newton)."""
        fz, dpi, g = (np.ascontiguousarray(c, dtype=float) for c in zip(*self.anchors))
        return newton_rows(np.array(p, dtype=float), np.ascontiguousarray(target, dtype=float),
                           np.asarray(self.fixed, dtype=float), self._positions, fz, dpi, g,
                           self.fz0p, self.lky, self._start_signs(), NEWTON_TOL, NEWTON_ITER,
                           MAX_HALVINGS)


def _solve(m: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solutions of the (W, n, n) systems m x = b; 0 where m is singular or not finite."""
    bad = ~np.all(np.isfinite(m), axis=(1, 2))
    with np.errstate(all="ignore"):
        bad |= ~(np.abs(np.linalg.det(np.where(bad[:, None, None], 1.0, m))) > 0)
    eye = np.broadcast_to(np.eye(m.shape[-1]), m.shape)
    out = np.linalg.solve(np.where(bad[:, None, None], eye, m), b[..., None])[..., 0]
    out[bad] = 0.0
    return np.where(np.isfinite(out), out, 0.0)


def _levels(values: np.ndarray) -> tuple[float, float, float]:
    """5 %, 50 % and 95 % quantiles of ``values``."""
    return tuple(float(q) for q in np.quantile(values, QUANTILES))


def kya_ridge(free: Sequence[str], x: np.ndarray, fz: np.ndarray,
              params: Mapping[str, float], dpi: np.ndarray | None = None,
              gamma_star: np.ndarray | None = None) -> KyaRidge | None:
    """The Fy0 stiffness map for a problem with free names ``free`` at the optimum ``x``, or
    None when PKY1, PKY2 and PKY4 are not all free or the loads ``fz`` [N] span less than
    20 % of Fz0' (three distinct levels are needed).

    Parameters
    ----------
    free : sequence of str      the problem's free coefficients
    x : ndarray                 their values at the optimum
    fz : ndarray [N]            the stage's vertical loads
    params : mapping            the .tir values (FNOMIN, NOMPRES, LFZO, LKY and the seven
                                coefficients of ALL_NAMES)
    dpi : ndarray [-], optional         the stage's relative pressure increments (PPY1, PPY2
                                        replaced only when given)
    gamma_star : ndarray [-], optional  the stage's camber sin(gamma) (PKY3, PKY5 replaced
                                        only when given)
    """
    if not set(NAMES) <= set(free):
        return None
    fz0p = float(params.get("LFZO", 1.0)) * float(params["FNOMIN"])
    f_lo, f_mid, f_hi = _levels(np.abs(np.asarray(fz, dtype=float)))
    if min(f_mid - f_lo, f_hi - f_mid) < 0.1 * fz0p:
        return None
    values = dict(zip(free, (float(v) for v in x)))
    if values["PKY2"] == 0 or values["PKY4"] == 0:
        return None
    d_ref, d_other = 0.0, None
    if dpi is not None and any(n in free for n in PRESSURE_NAMES):
        d = np.asarray(dpi, dtype=float)
        levels = _levels(d)
        d_ref = min(levels, key=abs)
        d_other = max((levels[0], levels[2]), key=lambda v: abs(v - d_ref))
        if levels[2] - levels[0] < MIN_PRESSURE_SPAN:
            d_ref, d_other = 0.0, None
    g_max = None
    if gamma_star is not None and any(n in free for n in CAMBER_NAMES):
        g_max = float(np.quantile(np.abs(np.asarray(gamma_star, dtype=float)), 0.95))
        g_max = g_max if g_max >= MIN_CAMBER else None
    nompres = float(params.get("NOMPRES", 0.0))

    def label(f, dp=None, g=None):
        tag = f"Kya@{f:.0f}N"
        if dp is not None and nompres > 0:
            tag += f",{nompres * (1 + dp) / 1e5:.2f}bar"
        if g is not None:
            tag += f",{np.rad2deg(np.arcsin(g)):.1f}deg"
        return tag

    names = list(NAMES)
    anchors = [(f, d_ref, 0.0) for f in (f_lo, f_mid, f_hi)]
    labels = [label(f, d_ref if d_other is not None else None) for f in (f_lo, f_mid, f_hi)]
    for group, level in ((PRESSURE_NAMES, d_other), (CAMBER_NAMES, g_max)):
        chosen = [n for n in group if n in free] if level is not None else []
        loads = (f_lo, f_hi) if len(chosen) == 2 else (f_mid,)[:len(chosen)]
        for f in loads:
            if group is PRESSURE_NAMES:
                anchors.append((f, level, 0.0))
                labels.append(label(f, level))
            else:
                anchors.append((f, d_ref, level))
                labels.append(label(f, d_ref if d_other is not None else None, level))
        names += chosen
    fixed = tuple(values.get(n, float(params.get(n, 0.0))) for n in ALL_NAMES)
    return KyaRidge(index=tuple(list(free).index(n) for n in names), names=tuple(names),
                    anchors=tuple(anchors), fixed=fixed, fz0p=fz0p,
                    lky=float(params.get("LKY", 1.0)),
                    start=tuple(values[n] for n in names), labels=tuple(labels))
