"""The error model of a discovery problem: noise level per group, correlation along sweeps.

Rig data are sweeps, and their noise is correlated along each sweep; treating it as
independent makes almost any candidate look significant. The diagnosis works on the
*variogram* of the residuals within sweeps, gamma(h) = mean((r[t+h] - r[t])^2)/2 for lags
h = 1..MAX_LAG: for AR(1) noise gamma(h) = s^2 (1 - phi^h), while a smooth misfit (the missing
effect itself) adds only ~h^2 * slope^2, which is negligible at small lags. So phi and the
marginal noise level s come from the noise, not from the missing effect.

Choice (:func:`choose_noise`): no sweeps (characteristic tables) -> independent; phi < PHI_MIN
-> independent; otherwise AR(1) prewhitening (Prais-Winsten per sweep) when the whitened
residuals are uncorrelated (phi_w < PHI_MIN), else cluster-robust statistics per sweep (when
there are at least MIN_CLUSTERS sweeps).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from identify.core.serial import Serial

__all__ = ["NoiseModel", "Sweeps", "sweep_index", "group_variogram", "lag1", "variogram",
           "fit_ar1", "choose_noise", "whiten", "noise_sigma", "PHI_MIN", "MAX_LAG",
           "MIN_CLUSTERS"]

PHI_MIN = 0.2
"""Below this lag-one correlation the noise is treated as independent [-]."""
MAX_LAG = 3
"""Largest variogram lag used [samples]."""
MIN_CLUSTERS = 10
"""Fewest sweeps for cluster-robust statistics."""
MIN_SWEEP = 5
"""Shortest sweep that counts as a sweep [samples]."""


@dataclass(frozen=True)
class NoiseModel(Serial):
    """The error model chosen for one problem.

    Attributes
    ----------
    kind : str            ``"independent"``, ``"ar1"`` or ``"cluster"``
    phi : float           AR(1) coefficient used for prewhitening (0 unless ``ar1``) [-]
    rho_lag1 : float      plain lag-one autocorrelation of the residuals within sweeps [-]
    rho_variogram : float lag-one correlation of the noise from the variogram [-]
    n_sweeps : int
    reason : str          one line: why this model
    """

    kind: str
    phi: float
    rho_lag1: float
    rho_variogram: float
    n_sweeps: int
    reason: str



class Sweeps(Sequence):
    """The sweeps of a problem: contiguous runs of points in data order.

    Behaves as a sequence of index arrays (one per sweep, as :func:`sweep_index` always
    returned) but keeps the layout as arrays, so that every statistic along sweeps is one
    vectorised pass over the points (no Python loop over sweeps).

    Attributes
    ----------
    label : ndarray of int (n,)
        Sweep number of each point (increasing in data order); -1 for a point in no sweep.
    """

    def __init__(self, label: np.ndarray):
        self.label = np.asarray(label, dtype=np.int64)
        n = self.label.size
        brk = np.ones(n, dtype=bool)
        brk[1:] = self.label[1:] != self.label[:-1]
        run_start = np.flatnonzero(brk)  # runs of equal labels, -1 runs included
        run_size = np.diff(np.append(run_start, n))
        is_sweep = self.label[run_start] >= 0 if n else np.zeros(0, dtype=bool)
        self._run = np.cumsum(brk) - 1
        self._run_sweep = is_sweep
        self._run_size = run_size
        self.starts = run_start[is_sweep]
        self.sizes = run_size[is_sweep]
        self.first = np.zeros(n, dtype=bool)
        self.first[self.starts] = True

    @classmethod
    def of(cls, sweeps: Sweeps | Sequence[np.ndarray] | None, n: int) -> Sweeps:
        """A Sweeps from itself, from a list of contiguous index arrays, or (None) every point
        alone."""
        if isinstance(sweeps, Sweeps):
            return sweeps
        if sweeps is None:
            return cls(np.arange(n))
        label = np.full(n, -1, dtype=np.int64)
        for i, idx in enumerate(sweeps):  # a caller's list: once, at construction
            label[np.asarray(idx, dtype=np.int64)] = i
        return cls(label)

    @property
    def n(self) -> int:
        return self.label.size

    def __len__(self) -> int:
        return self.starts.size

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        return np.arange(self.starts[i], self.starts[i] + self.sizes[i])

    def subset(self, mask: np.ndarray) -> Sweeps:
        """The sweeps of the points in ``mask``, in the local numbering of those points."""
        return Sweeps(self.label[np.asarray(mask, dtype=bool)])

    def at_least(self, size: int) -> Sweeps:
        """Only the sweeps of at least ``size`` points (the others' points in no sweep)."""
        keep = (self._run_sweep & (self._run_size >= size))[self._run] if self.n else \
            np.zeros(0, dtype=bool)
        return Sweeps(np.where(keep, self.label, -1))

    def pairs(self, h: int) -> np.ndarray:
        """Bool (n - h,): points t with t + h in the same sweep."""
        if h >= self.n:
            return np.zeros(0, dtype=bool)
        a, b = self.label[:-h] if h else self.label, self.label[h:]
        return (a == b) & (a >= 0)

    def sums(self, a: np.ndarray) -> np.ndarray:
        """Per-sweep sums of the rows of ``a`` ((n,) or (n, k)) -> (sweeps,) or (sweeps, k)."""
        if not len(self):
            return np.zeros((0,) + np.shape(a)[1:])
        inside = self.label >= 0
        if inside.all():
            return np.add.reduceat(a, self.starts, axis=0)
        pos = np.cumsum(inside) - 1  # sweeps are contiguous: reduce over the inside points
        return np.add.reduceat(a[inside], pos[self.starts], axis=0)


def sweep_index(sweeps: np.ndarray | None, n: int) -> Sweeps:
    """The sweeps of a problem in data order (each point alone when ``sweeps`` is None): a new
    sweep starts wherever the sweep id changes."""
    if sweeps is None:
        return Sweeps(np.arange(n))
    sweeps = np.asarray(sweeps)
    brk = np.ones(n, dtype=bool)
    brk[1:] = sweeps[1:] != sweeps[:-1]
    return Sweeps(np.cumsum(brk) - 1)


def lag1(r: np.ndarray, index) -> float:
    """Lag-one autocorrelation of ``r`` within sweeps (pooled; NaN without pairs) [-]."""
    sw = Sweeps.of(index, r.size).at_least(2)
    inside = sw.label >= 0
    if not inside.any():
        return float("nan")
    lab = sw.label[inside]
    _, inv = np.unique(lab, return_inverse=True)
    mean = np.bincount(inv, r[inside]) / np.bincount(inv)
    x = np.zeros(r.size)
    x[inside] = r[inside] - mean[inv]
    v = sw.pairs(1)
    num = float(x[:-1][v] @ x[1:][v])
    den = float(x[inside] @ x[inside])
    return num / den if den > 0 else float("nan")


def variogram(r: np.ndarray, index, max_lag: int = MAX_LAG) -> np.ndarray:
    """Semivariogram gamma(h), h = 1..max_lag, pooled over sweeps (NaN without pairs)."""
    sw = Sweeps.of(index, r.size)
    out = np.full(max_lag, np.nan)
    for h in range(1, max_lag + 1):
        v = sw.pairs(h)
        if v.any():
            d = (r[h:] - r[:-h])[v]
            out[h - 1] = 0.5 * float(d @ d) / d.size
    return out


def group_variogram(r: np.ndarray, index, groups: np.ndarray, h: int = 1
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Lag-``h`` semivariogram of each group (pairs within a sweep and a group).

    Returns
    -------
    gamma : ndarray (n,)   the point's group's gamma(h) (NaN when the group has no pairs)
    inverse : ndarray (n,) group number of each point
    """
    sw = Sweeps.of(index, r.size)
    _, inv = np.unique(np.asarray(groups), return_inverse=True)
    G = int(inv.max()) + 1 if inv.size else 0
    v = sw.pairs(h)
    if h < r.size:
        v &= inv[:-h] == inv[h:]
        d = (r[h:] - r[:-h])[v]
        g = inv[:-h][v]
    else:
        d, g = np.zeros(0), np.zeros(0, dtype=np.int64)
    cnt = np.bincount(g, minlength=G)
    ssq = np.bincount(g, d * d, minlength=G)
    with np.errstate(invalid="ignore", divide="ignore"):
        gam = np.where(cnt > 0, 0.5 * ssq / np.maximum(cnt, 1), np.nan)
    return gam[inv], inv


def fit_ar1(gam: np.ndarray) -> tuple[float, float]:
    """(phi, s^2) of gamma(h) = s^2 (1 - phi^h) by least squares on a grid of phi."""
    h = np.arange(1, gam.size + 1)
    ok = np.isfinite(gam)
    if not ok.any() or gam[0] <= 0:
        return 0.0, float(gam[0]) if ok[0] else float("nan")
    best = (np.inf, 0.0, float(gam[0]))
    for phi in np.linspace(0.0, 0.995, 400):
        shape = 1.0 - phi ** h[ok]
        s2 = float(shape @ gam[ok]) / float(shape @ shape)
        rel = (gam[ok] - s2 * shape) / gam[0]
        err = float(rel @ rel)
        if err < best[0]:
            best = (err, float(phi), s2)
    return best[1], best[2]


def whiten(a: np.ndarray, index, phi: float) -> np.ndarray:
    """Prais-Winsten transform per sweep: x1*sqrt(1 - phi^2), x_t - phi*x_(t-1).

    ``a`` is (n,) or (n, k); ``index`` the sweeps (:class:`Sweeps` or index arrays). Points in
    no sweep are scaled like the first point of a sweep.
    """
    if phi == 0.0:
        return a
    a = np.asarray(a, dtype=float)
    sw = Sweeps.of(index, a.shape[0])
    out = np.array(a, dtype=float, copy=True)
    v = sw.pairs(1)
    out[1:][v] = a[1:][v] - phi * a[:-1][v]
    head = np.ones(a.shape[0], dtype=bool)
    head[1:] = ~v
    out[head] = np.sqrt(1.0 - phi * phi) * a[head]
    return out


def noise_sigma(r: np.ndarray, index, groups: np.ndarray,
                phi: float) -> np.ndarray:
    """Marginal noise std per point from the lag-one semivariogram of its group (robust to a
    smooth misfit): s_g = sqrt(gamma_g(1)/(1 - phi)) [unit of r]; NaN where a group has no
    pairs."""
    gam, _ = group_variogram(r, index, groups, 1)
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(gam) & (gam > 0), np.sqrt(gam / max(1.0 - phi, 1e-3)),
                        np.nan)


def choose_noise(r: np.ndarray, index: list[np.ndarray]) -> NoiseModel:
    """Pick the error model from residuals ``r`` (already scaled to unit-ish noise)."""
    sweeps = Sweeps.of(index, r.size).at_least(MIN_SWEEP)
    n_sweeps = len(sweeps)
    rho = lag1(r, sweeps)
    if n_sweeps == 0:
        return NoiseModel("independent", 0.0, rho, float("nan"), 0,
                          "no sweeps: points treated as independent")
    phi, _ = fit_ar1(variogram(r, sweeps))
    if phi < PHI_MIN:
        return NoiseModel("independent", 0.0, rho, phi, n_sweeps,
                          f"noise correlation along sweeps {phi:.2f} < {PHI_MIN}")
    phi_w, _ = fit_ar1(variogram(whiten(r, sweeps, phi), sweeps))
    if phi_w < PHI_MIN:
        return NoiseModel("ar1", phi, rho, phi, n_sweeps,
                          f"AR(1) noise along sweeps, phi = {phi:.2f}; prewhitened")
    if n_sweeps >= MIN_CLUSTERS:
        return NoiseModel("cluster", 0.0, rho, phi, n_sweeps,
                          f"correlated noise not AR(1) (phi = {phi:.2f}, after prewhitening "
                          f"{phi_w:.2f}): cluster-robust per sweep")
    return NoiseModel("ar1", phi, rho, phi, n_sweeps,
                      f"correlated noise not AR(1) (after prewhitening {phi_w:.2f}) but only "
                      f"{n_sweeps} sweeps for cluster-robust statistics: AR(1) prewhitened")
