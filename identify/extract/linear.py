"""Straight-line fits and the automatic search for the linear part of a curve.

The Flatplank stiffness tests (locked hub, parking) give a force that is linear in the
displacement only over part of the run: start-up slack and ringing come first, saturation and
stick-slip last. :func:`linear_window` finds the longest stretch that a straight line explains
to within the run's own noise, by testing every candidate window at once (prefix sums, no loop
over samples): the line's residual must look like noise, and a quadratic term must not be
significant (which rejects both the convex start-up and the concave saturation onset).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.stats import chi2, norm
from scipy.stats import f as f_dist

from identify.core.serial import Serial

__all__ = ["LineFit", "line_fit", "noise_sigma", "smooth", "linear_window"]

#: Candidate window edges per run (a coarser grid than the samples on long runs).
_EDGES = 64


@dataclass(frozen=True)
class LineFit(Serial):
    """A least-squares line y = slope * x + intercept over a window of samples.

    Attributes
    ----------
    slope, intercept : float
        Line coefficients [unit of y per unit of x], [unit of y].
    lo, hi : float
        Window in x (first and last sample used) [unit of x].
    i0, i1 : int
        Sample indices of the window (i1 exclusive).
    n : int
        Samples used.
    r2 : float
        Coefficient of determination [-].
    rmse : float
        Root-mean-square residual [unit of y].
    slope_se : float
        Standard error of the slope from the residuals [unit of y per unit of x].
    """

    slope: float
    intercept: float
    lo: float
    hi: float
    i0: int
    i1: int
    n: int
    r2: float
    rmse: float
    slope_se: float



def line_fit(x: np.ndarray, y: np.ndarray, i0: int = 0, i1: int | None = None) -> LineFit:
    """Least-squares line through ``y[i0:i1]`` against ``x[i0:i1]``."""
    i1 = len(x) if i1 is None else i1
    xs, ys = np.asarray(x[i0:i1], float), np.asarray(y[i0:i1], float)
    n = xs.size
    dx = xs - xs.mean()
    sxx = float(dx @ dx)
    slope = float(dx @ (ys - ys.mean()) / sxx) if sxx > 0 else 0.0
    intercept = float(ys.mean() - slope * xs.mean())
    res = ys - (slope * xs + intercept)
    sse = float(res @ res)
    sst = float(((ys - ys.mean()) ** 2).sum())
    r2 = 1.0 - sse / sst if sst > 0 else 1.0
    se = np.sqrt(sse / max(n - 2, 1) / sxx) if sxx > 0 else np.inf
    return LineFit(slope, intercept, float(xs.min()), float(xs.max()), int(i0), int(i1), n,
                   float(r2), float(np.sqrt(sse / n)), float(se))


def noise_sigma(y: np.ndarray, floor: float = 0.0) -> float:
    """Robust per-sample noise level of a smooth signal plus white noise [unit of y].

    Second differences cancel the straight parts of the signal; their lower quartile (of the
    absolute values) ignores the large ones that bends, start-up ringing and stick-slip drops
    make, as long as a quarter of the stretch is straight. ``floor`` bounds the result from
    below (noise-free data still need a tolerance for round-off).
    """
    d2 = np.abs(np.diff(np.asarray(y, float), 2))
    if d2.size < 4:
        return float(floor)
    # |N(0, 6 sigma^2)| has its lower quartile at 0.31864 sqrt(6) sigma
    return float(max(np.quantile(d2, 0.25) / (0.31864 * np.sqrt(6.0)), floor))


def smooth(y: np.ndarray, frac: float = 0.04) -> np.ndarray:
    """Moving average over ``frac`` of the run (at least 3 samples, odd) [unit of y]."""
    w = max(3, int(round(frac * y.size)) | 1)
    return uniform_filter1d(np.asarray(y, float), w, mode="nearest")


def _prefix(*cols: np.ndarray) -> list[np.ndarray]:
    return [np.concatenate([[0.0], np.cumsum(c)]) for c in cols]


def linear_window(x: np.ndarray, y: np.ndarray, sigma: float | None = None, *,
                  min_points: int = 8, min_fraction: float = 0.12, level: float = 0.999,
                  noise_level: float = 0.9999,
                  must_contain: float | None = None) -> LineFit | None:
    """The longest window over which ``y`` is a straight line in ``x`` within the noise.

    Every candidate window (edges on a grid of at most 64 points) is tested at once:

    * curvature: the quadratic and cubic terms of a cubic through the window are not
      significant (F test against the window's own residual, so no noise level is needed;
      the cubic term catches the odd bends of a window centred between two saturations);
    * structure: the lag-one autocorrelation of the line's residuals is within the white-noise
      band (start-up ringing, stick-slip and slow bends all correlate the residuals);
    * size (when ``sigma`` is given): the residual variance is not beyond the noise level.

    Parameters
    ----------
    x, y : numpy.ndarray
        Abscissa (monotonic over the search range) and signal, same length.
    sigma : float, optional
        Per-sample noise standard deviation of ``y`` [unit of y] (:func:`noise_sigma`).
    min_points : int
        Fewest samples in a window.
    min_fraction : float
        Fewest samples as a fraction of ``len(x)`` [-].
    level : float
        Confidence level of the curvature and autocorrelation tests [-].
    noise_level : float
        Confidence level of the residual-size test [-] (lenient: ``sigma`` is itself an
        estimate).
    must_contain : float, optional
        Only windows whose x range contains this value (e.g. psi = 0 for parking).

    Returns
    -------
    LineFit or None
        The window with the smallest slope standard error among those that pass (the most
        informative linear stretch); None when no window passes.
    """
    x = np.asarray(x, float)
    y = y_in = np.asarray(y, float)
    m = x.size
    need = max(min_points, int(np.ceil(min_fraction * m)), 5)
    if m < need:
        return None
    # scale x to [-1, 1] so the batched normal equations stay well conditioned
    mid, half = 0.5 * (x.max() + x.min()), 0.5 * (x.max() - x.min()) or 1.0
    u = (x - mid) / half
    # work on the residual of one global line: every window fit is unchanged (its own line
    # absorbs it) but the sums of squares no longer cancel catastrophically
    y = y - np.polyval(np.polyfit(u, y, 1), u)
    powers = _prefix(*(u ** k for k in range(7)))
    moments = _prefix(*(u ** k * y for k in range(4)))
    (syy,) = _prefix(y * y)
    du, dy = np.diff(u), np.diff(y)
    d_uu, d_uy, d_yy = _prefix(du * du, du * dy, dy * dy)
    edges = np.unique(np.linspace(0, m, min(m, _EDGES) + 1).round().astype(int))
    i0, i1 = np.meshgrid(edges, edges, indexing="ij")
    ok = i1 - i0 >= need
    if must_contain is not None:
        ends = np.stack([x[np.minimum(i0, m - 1)], x[np.maximum(i1 - 1, 0)]])
        ok &= (ends.min(0) <= must_contain) & (ends.max(0) >= must_contain)
    i0, i1 = i0[ok], i1[ok]
    if i0.size == 0:
        return None
    a = np.stack([p[i1] - p[i0] for p in powers], -1)       # sum u^k, k = 0..6
    b = np.stack([q[i1] - q[i0] for q in moments], -1)      # sum u^k y, k = 0..3
    yy = syy[i1] - syy[i0]
    n = a[:, 0]
    sxx = a[:, 2] - a[:, 1] ** 2 / n
    slope = (b[:, 1] - a[:, 1] * b[:, 0] / n) / sxx
    sse1 = np.maximum(yy - b[:, 0] ** 2 / n - slope ** 2 * sxx, 0.0)
    gram = a[:, np.add.outer(np.arange(4), np.arange(4))]  # Hankel: sum u^(j+k)
    coef = np.linalg.solve(gram, b[..., None])[..., 0]
    sse3 = np.clip(yy - (coef * b).sum(-1), 0.0, sse1)
    # round-off level of the sums: below it a residual is zero (noise-free data)
    eps = 1e-12 * float(syy[-1]) + 1e-300
    curv = 0.5 * (sse1 - sse3) / ((sse3 + eps) / (n - 4))
    # sum of squared residual differences: sum (dy - slope du)^2 over the window's pairs
    j0, j1 = i0, i1 - 1
    ssd = (d_yy[j1] - d_yy[j0]) - 2 * slope * (d_uy[j1] - d_uy[j0]) + \
        slope ** 2 * (d_uu[j1] - d_uu[j0])
    r1 = 1.0 - 0.5 * (ssd + 2 * eps) / (sse1 + eps)
    passes = (curv <= f_dist.ppf(level, 2, n - 4)) & \
        (np.abs(r1) * np.sqrt(n) <= norm.ppf(0.5 + 0.5 * level))
    if sigma is not None and sigma > 0:
        passes &= sse1 / sigma ** 2 <= chi2.ppf(noise_level, n - 2)
    if not passes.any():
        return None
    best = np.flatnonzero(passes)[np.argmax(sxx[passes])]
    return line_fit(x, y_in, int(i0[best]), int(i1[best]))
