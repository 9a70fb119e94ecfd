"""CFz from vertical runs: a quadratic Fz(rho) per run, averaged over the start positions.

The tyre is pressed down at constant speed to the turn-back load and unloaded; only the loading
branch is used (unloading shows hysteresis). Each run gives Fz = c0 + c1 rho + c2 rho^2 over the
loaded part (Fz above 5 % of the maximum, i.e. after contact); the coefficients are averaged
over the start positions of a pressure, and CFz at a load F is the slope at the deflection that
carries F: CFz = sqrt(c1^2 + 4 c2 (F - c0)).
"""
from __future__ import annotations

from typing import Iterable, Mapping

import numpy as np

from identify.extract.diagnostics import Part, RunDiagnostic, row
from identify.extract.flags import Thresholds, condition_flags, spread_flag
from identify.extract.runs import RunData, cell_label

__all__ = ["fit_quadratic", "cfz_at_load", "extract_vertical"]


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
        ``coef`` (c0 [N], c1 [N/m], c2 [N/m^2]), ``window`` (rho range [m]), ``n``, ``r2``,
        ``rmse`` [N] and ``fz_max`` [N] (the fitted load at the largest deflection).
    """
    top = int(np.argmax(rho))
    rho_up, fz_up = rho[:top + 1], fz[:top + 1]
    keep = fz_up >= 0.05 * fz_up.max()
    r, f = rho_up[keep], fz_up[keep]
    design = np.stack([np.ones_like(r), r, r * r], axis=1)
    coef, *_ = np.linalg.lstsq(design, f, rcond=None)
    res = f - design @ coef
    sst = float(((f - f.mean()) ** 2).sum())
    return {"coef": coef, "window": (float(r.min()), float(r.max())), "n": int(r.size),
            "r2": 1.0 - float(res @ res) / sst if sst > 0 else 1.0,
            "rmse": float(np.sqrt(np.mean(res ** 2))),
            "fz_max": float(coef @ [1.0, r.max(), r.max() ** 2])}


def cfz_at_load(coef: np.ndarray, load: np.ndarray | float) -> np.ndarray:
    """CFz [N/m] of Fz = c0 + c1 rho + c2 rho^2 at the deflection carrying ``load`` [N]."""
    c0, c1, c2 = coef
    return np.sqrt(np.maximum(c1 ** 2 + 4.0 * c2 * (np.asarray(load, float) - c0), 0.0))


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
    by_p: dict[float, list[np.ndarray]] = {}
    for run in runs:
        fit = fit_quadratic(run.ch["hub_z"], run.ch["Fz"])
        mine = condition_flags(run, th, measured_load=fit["fz_max"])
        flags += mine
        by_p.setdefault(run.p_bar, []).append(fit["coef"])
        c0, c1, c2 = fit["coef"]
        diags.append(RunDiagnostic(
            run.run, run.test, "CFz", run.p_bar, nominal_load, run.start,
            float(cfz_at_load(fit["coef"], nominal_load)), fit["window"], "m", fit["n"],
            fit["r2"], fit["rmse"], tuple(f.flag for f in mine),
            {"c0_N": c0, "c1_N_per_m": c1, "c2_N_per_m2": c2, "fz_max_N": fit["fz_max"]}))
    for p, coefs in sorted(by_p.items()):
        mean = np.mean(coefs, axis=0)
        at = sorted(set(loads.get(p, ()))) or [nominal_load]
        rows += [row("CFz", p, fz, float(v)) for fz, v in zip(at, cfz_at_load(mean, at))]
        per_run = [float(cfz_at_load(c, nominal_load)) for c in coefs]
        found = spread_flag(cell_label("vertical", p, nominal_load), "vertical", "CFz", per_run,
                            [0.0] * len(per_run), th)
        flags += [found] if found else []
    return Part(tuple(rows), tuple(diags), tuple(flags))
