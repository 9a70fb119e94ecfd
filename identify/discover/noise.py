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

from dataclasses import dataclass

import numpy as np

from identify.core.jsonsafe import json_float

__all__ = ["NoiseModel", "sweep_index", "lag1", "variogram", "fit_ar1", "choose_noise",
           "whiten", "noise_sigma", "PHI_MIN", "MAX_LAG", "MIN_CLUSTERS"]

PHI_MIN = 0.2
"""Below this lag-one correlation the noise is treated as independent [-]."""
MAX_LAG = 3
"""Largest variogram lag used [samples]."""
MIN_CLUSTERS = 10
"""Fewest sweeps for cluster-robust statistics."""
MIN_SWEEP = 5
"""Shortest sweep that counts as a sweep [samples]."""


@dataclass(frozen=True)
class NoiseModel:
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

    def to_dict(self) -> dict:
        return {"kind": self.kind, "phi": self.phi, "rho_lag1": json_float(self.rho_lag1),
                "rho_variogram": json_float(self.rho_variogram), "n_sweeps": self.n_sweeps,
                "reason": self.reason}


def sweep_index(sweeps: np.ndarray | None, n: int) -> list[np.ndarray]:
    """Index arrays of the sweeps, in data order (each point alone when ``sweeps`` is None)."""
    if sweeps is None:
        return [np.array([i]) for i in range(n)]
    sweeps = np.asarray(sweeps)
    brk = np.ones(n, dtype=bool)
    brk[1:] = sweeps[1:] != sweeps[:-1]
    starts = np.flatnonzero(brk)
    return [np.arange(a, b) for a, b in zip(starts, list(starts[1:]) + [n])]


def lag1(r: np.ndarray, index: list[np.ndarray]) -> float:
    """Lag-one autocorrelation of ``r`` within sweeps (pooled; NaN without pairs) [-]."""
    num = den = 0.0
    for idx in index:
        if idx.size < 2:
            continue
        x = r[idx] - r[idx].mean()
        num += float(x[1:] @ x[:-1])
        den += float(x @ x)
    return num / den if den > 0 else float("nan")


def variogram(r: np.ndarray, index: list[np.ndarray], max_lag: int = MAX_LAG) -> np.ndarray:
    """Semivariogram gamma(h), h = 1..max_lag, pooled over sweeps (NaN without pairs)."""
    out = np.full(max_lag, np.nan)
    for h in range(1, max_lag + 1):
        d = [r[idx[h:]] - r[idx[:-h]] for idx in index if idx.size > h]
        if d:
            d = np.concatenate(d)
            out[h - 1] = 0.5 * float(d @ d) / d.size
    return out


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


def whiten(a: np.ndarray, index: list[np.ndarray], phi: float) -> np.ndarray:
    """Prais-Winsten transform per sweep: x1*sqrt(1 - phi^2), x_t - phi*x_(t-1).

    ``a`` is (n,) or (n, k); sweeps are the index arrays of :func:`sweep_index`.
    """
    if phi == 0.0:
        return a
    out = np.array(a, dtype=float, copy=True)
    c = np.sqrt(1.0 - phi * phi)
    for idx in index:
        first = idx[0]
        out[idx[1:]] = a[idx[1:]] - phi * a[idx[:-1]]
        out[first] = c * a[first]
    return out


def noise_sigma(r: np.ndarray, index: list[np.ndarray], groups: np.ndarray,
                phi: float) -> np.ndarray:
    """Marginal noise std per point from the lag-one semivariogram of its group (robust to a
    smooth misfit): s_g = sqrt(gamma_g(1)/(1 - phi)) [unit of r]; NaN where a group has no
    pairs."""
    out = np.full(r.size, np.nan)
    groups = np.asarray(groups)
    for g in np.unique(groups):
        sel = groups == g
        sub = [idx[sel[idx]] for idx in index]
        gam = variogram(r, [s for s in sub if s.size > 1], 1)[0]
        if np.isfinite(gam) and gam > 0:
            out[sel] = np.sqrt(gam / max(1.0 - phi, 1e-3))
    return out


def choose_noise(r: np.ndarray, index: list[np.ndarray]) -> NoiseModel:
    """Pick the error model from residuals ``r`` (already scaled to unit-ish noise)."""
    sweeps = [idx for idx in index if idx.size >= MIN_SWEEP]
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
