"""CFz from vertical runs: a quadratic Fz(rho) per run, averaged over the start positions.

The tyre is pressed down at constant speed to the turn-back load and unloaded; only the loading
branch is used (unloading shows hysteresis). Each run gives Fz = c0 + c1 rho + c2 rho^2 over the
loaded part (from the deflection at which a smoothed Fz first reaches 5 % of its maximum, i.e.
after contact); the coefficients are averaged over the start positions of a pressure, and CFz
at a load F is the slope at the deflection that carries F: CFz = sqrt(c1^2 + 4 c2 (F - c0)).

The start of the loaded part is a deflection, found once on the smoothed force: selecting the
samples by their own noisy Fz would keep the samples near the threshold whose noise is
positive, lift the low end of the curve and bias CFz (-0.2 % at 3 kN, +0.13 % at 7 kN over
200 noise seeds at the default artefacts and 300 samples per run).
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from identify.extract.diagnostics import Part, RunDiagnostic, row
from identify.extract.flags import Thresholds, condition_flags, spread_flag
from identify.extract.linear import smooth
from identify.extract.runs import RunData, cell_label

__all__ = ["fit_quadratic", "cfz_at_load", "cfz_se", "extract_vertical"]


def fit_quadratic(rho: np.ndarray, fz: np.ndarray) -> dict:
    """Least-squares Fz = c0 + c1 rho + c2 rho^2 over the loading branch of one run.

    Parameters
    ----------
    rho : numpy.ndarray
        Deflection (hub displacement towards the plank) [m].
    fz : numpy.ndarray
        Contact load [N].

    Returns
    -------
    dict
        ``coef`` (c0 [N], c1 [N/m], c2 [N/m^2]), ``cov`` (their 3 x 3 covariance from the
        residuals), ``window`` (rho range [m]), ``n``, ``r2``, ``rmse`` [N] and ``fz_max`` [N]
        (the fitted load at the largest deflection).
    """
    top = int(np.argmax(rho))
    smoothed = smooth(fz[:top + 1])
    contact = int(np.argmax(smoothed >= 0.05 * smoothed.max()))
    r, f = rho[contact:top + 1], fz[contact:top + 1]
    design = np.stack([np.ones_like(r), r, r * r], axis=1)
    coef, *_ = np.linalg.lstsq(design, f, rcond=None)
    res = f - design @ coef
    sst = float(((f - f.mean()) ** 2).sum())
    cov = float(res @ res) / max(r.size - 3, 1) * np.linalg.pinv(design.T @ design)
    return {"coef": coef, "cov": cov, "window": (float(r.min()), float(r.max())), "n": int(r.size),
            "r2": 1.0 - float(res @ res) / sst if sst > 0 else 1.0,
            "rmse": float(np.sqrt(np.mean(res ** 2))),
            "fz_max": float(coef @ [1.0, r.max(), r.max() ** 2])}


def cfz_at_load(coef: np.ndarray, load: np.ndarray | float) -> np.ndarray:
    """CFz [N/m] of Fz = c0 + c1 rho + c2 rho^2 at the deflection carrying ``load`` [N]."""
    c0, c1, c2 = coef
    return np.sqrt(np.maximum(c1 ** 2 + 4.0 * c2 * (np.asarray(load, float) - c0), 0.0))


def cfz_se(coef: np.ndarray, cov: np.ndarray, load: np.ndarray | float) -> np.ndarray:
    """Standard error [N/m] of :func:`cfz_at_load` from the coefficients' covariance ``cov``
    (first order: the gradient of CFz = sqrt(c1^2 + 4 c2 (F - c0)) through ``cov``)."""
    c0, c1, c2 = coef
    load = np.asarray(load, float)
    c = cfz_at_load(coef, load)
    grad = np.stack(np.broadcast_arrays(-2.0 * c2, c1, 2.0 * (load - c0)), -1) / c[..., None]
    return np.sqrt(np.einsum("...i,ij,...j->...", grad, cov, grad))


def extract_vertical(runs: list[RunData], loads: Mapping[float, Iterable[float]],
                     nominal_load: float, th: Thresholds) -> Part:
    """CFz per pressure at the loads the other tests were run at.

    Parameters
    ----------
    runs : list of RunData
        Vertical runs.
    loads : mapping
        Pressure [bar] -> loads [N] at which to report CFz (the set loads of the folder's
        other Flatplank tests at that pressure).
    nominal_load : float
        Load [N] used when a pressure has no other tests, and for the spread check.
    th : Thresholds
        Flag thresholds.
    """
    rows, diags, flags = [], [], []
    by_p: dict[float, list[dict]] = {}
    for run in runs:
        fit = fit_quadratic(run.ch["hub_z"], run.ch["Fz"])
        mine = condition_flags(run, th, measured_load=fit["fz_max"])
        flags += mine
        by_p.setdefault(run.p_bar, []).append(fit)
        c0, c1, c2 = fit["coef"]
        diags.append(RunDiagnostic(
            run.run, run.test, "CFz", run.p_bar, nominal_load, run.start,
            float(cfz_at_load(fit["coef"], nominal_load)), fit["window"], "m", fit["n"],
            fit["r2"], fit["rmse"], tuple(f.flag for f in mine),
            {"c0_N": c0, "c1_N_per_m": c1, "c2_N_per_m2": c2, "fz_max_N": fit["fz_max"],
             "cov_coef": fit["cov"].tolist(),
             "se_N_per_m": float(cfz_se(fit["coef"], fit["cov"], nominal_load))}))
    for p, fits in sorted(by_p.items()):
        mean = np.mean([f["coef"] for f in fits], axis=0)
        at = sorted(set(loads.get(p, ()))) or [nominal_load]
        rows += [row("CFz", p, fz, float(v)) for fz, v in zip(at, cfz_at_load(mean, at))]
        per_run = [float(cfz_at_load(f["coef"], nominal_load)) for f in fits]
        errors = [float(cfz_se(f["coef"], f["cov"], nominal_load)) for f in fits]
        found = spread_flag(cell_label("vertical", p, nominal_load), "vertical", "CFz", per_run,
                            errors, th)
        flags += [found] if found else []
    return Part(tuple(rows), tuple(diags), tuple(flags))
