"""A fitted .tir against the truth it was simulated from, over the measured operating range.

The question an engineer asks of a fitted file is not how close each coefficient is (several
trade against each other) but how close the *tyre* is: the forces and stiffnesses the vehicle
model will see. :func:`compare_to_truth` evaluates both parameter sets with the same model
(:func:`identify.model.evaluate.evaluate`) and reports, per quantity, the RMS of the
difference relative to the RMS of the truth, in per cent:

- forces and moments **Fx, Fy, Mz, Mx** at the operating points the MF stages were fitted to
  (the MF rows of measured_vs_model.csv: every measured load, pressure, slip and camber
  combination, each quantity at the rows of its own channel), tolerance 1 %;
- stiffnesses **Cx, Cy, Cz** (model outputs), the relaxation length **sigma_y** = Kya/Cy and
  the yaw stiffness **CMz** (from YAW_STIFFNESS, PCMZ1..3 and CMZ_FORM, docs/relations.md) on a
  9 x 7 grid of load and pressure spanning the fitted Flatplank points of the matching
  characteristic (CFx, CFy, CFz, sigma_y, CMz), tolerance 2 %.

A quantity without fitted points of its kind is left out. ``bench/truth_compare.py`` runs it
over simulated seeds; the trials test (tests/trials/test_truth_trials.py) checks the
tolerances.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from identify.model import relations as rel
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE

__all__ = ["FORCE_TOLERANCE_PCT", "STIFFNESS_TOLERANCE_PCT", "QuantityError",
           "TruthComparison", "compare_to_truth", "cmz"]

FORCE_TOLERANCE_PCT = 1.0
STIFFNESS_TOLERANCE_PCT = 2.0
FLATPLANK_SPEED = 0.05
"""Rolling speed of the stiffness evaluation [m/s] (Flatplank crawl speed)."""
GRID = (9, 7)
"""Loads x pressures of the stiffness grid."""

FORCES = {"Fx": "Fx", "Fy": "Fy", "Mz": "Mz", "Mx": "Mx"}
"""Compared force/moment -> the measured_vs_model quantity whose MF rows give its points."""
STIFFNESSES = {"Cx": "CFx", "Cy": "CFy", "Cz": "CFz", "sigma_y": "sigma_y", "CMz": "CMz"}
"""Compared stiffness -> the characteristic whose fitted points span its grid."""
_OUTPUT = {"Cx": "Cx", "Cy": "Cy", "Cz": "Cz", "sigma_y": "sigmay"}


@dataclass(frozen=True)
class QuantityError:
    """One quantity compared.

    Attributes
    ----------
    name : str
    rms_pct : float        RMS(fitted - truth) / RMS(truth) x 100 [%]
    max_pct : float        max |fitted - truth| / RMS(truth) x 100 [%]
    n_points : int
    tolerance_pct : float
    where : str            the operating points (for the report)
    """

    name: str
    rms_pct: float
    max_pct: float
    n_points: int
    tolerance_pct: float
    where: str

    @property
    def ok(self) -> bool:
        return bool(self.rms_pct <= self.tolerance_pct)


@dataclass(frozen=True)
class TruthComparison:
    """Every quantity compared, in the order of :data:`FORCES` then :data:`STIFFNESSES`."""

    quantities: tuple[QuantityError, ...]

    @property
    def ok(self) -> bool:
        return all(q.ok for q in self.quantities)

    def __getitem__(self, name: str) -> QuantityError:
        for q in self.quantities:
            if q.name == name:
                return q
        raise KeyError(name)

    def table(self) -> str:
        """Plain-text table: quantity, RMS %, max %, tolerance, points, ok."""
        lines = [f"{'quantity':<9} {'rms %':>8} {'max %':>8} {'tol %':>6} {'points':>7}  ok  "
                 "where"]
        for q in self.quantities:
            lines.append(f"{q.name:<9} {q.rms_pct:8.3f} {q.max_pct:8.3f} "
                         f"{q.tolerance_pct:6.1f} {q.n_points:7d}  "
                         f"{'yes' if q.ok else 'NO '} {q.where}")
        return "\n".join(lines)


def cmz(P: Mapping[str, float], fz, p_pa) -> np.ndarray:
    """Yaw stiffness CMz [N m/rad] of a .tir at loads ``fz`` [N] and pressures ``p_pa`` [Pa]
    (form T1 or T2 by CMZ_FORM)."""
    fz0, p0 = float(P["FNOMIN"]), float(P["NOMPRES"])
    dp = rel.dpi(np.asarray(p_pa, float), p0)
    if int(round(float(P.get("CMZ_FORM", 1.0)))) == 2:
        return rel.cmz_t2(fz, dp, P["YAW_STIFFNESS"], P["PCMZ1"], P.get("PCMZ2", 0.0),
                          P.get("PCMZ3", 0.0), fz0)
    return rel.cmz_t1(fz, dp, P["YAW_STIFFNESS"], P["PCMZ1"], fz0)


def _error(name: str, fitted: np.ndarray, truth: np.ndarray, tol: float,
           where: str) -> QuantityError:
    ok = np.isfinite(fitted) & np.isfinite(truth)
    d, t = fitted[ok] - truth[ok], truth[ok]
    scale = math.sqrt(float(np.mean(t ** 2))) if t.size else math.nan
    rms = 100.0 * math.sqrt(float(np.mean(d ** 2))) / scale if t.size else math.nan
    mx = 100.0 * float(np.max(np.abs(d))) / scale if t.size else math.nan
    return QuantityError(name, rms, mx, int(t.size), tol, where)


def _numeric(P: Mapping) -> dict[str, float]:
    return {k: float(v) for k, v in P.items() if isinstance(v, (int, float, np.floating))}


def compare_to_truth(fitted: Mapping[str, float], truth: Mapping[str, float],
                     points: pd.DataFrame) -> TruthComparison:
    """Compare a fitted .tir with the truth over the fitted data's operating range.

    Parameters
    ----------
    fitted, truth : mapping
        .tir values in SI (``read_tir(path).params()``; truth.json's ``tir``).
    points : DataFrame
        measured_vs_model.csv of the fit (columns relation, quantity, pi_bar, Fz_N, gamma_deg,
        alpha_rad, kappa, Vx_mps).

    Returns
    -------
    TruthComparison
    """
    F, T = _numeric(fitted), _numeric(truth)
    out: list[QuantityError] = []
    q = points["quantity"].astype(str).to_numpy()
    mf = (points["relation"].astype(str) == "MF").to_numpy()
    for name, quantity in FORCES.items():
        rows = points[mf & (q == quantity)]
        if rows.empty:
            continue
        cols = [rows[c].to_numpy(float) for c in ("Fz_N", "kappa", "alpha_rad", "gamma_deg",
                                                  "Vx_mps", "pi_bar")]
        fz, kappa, alpha, gamma_deg, vx, pi = (np.nan_to_num(c) for c in cols)
        args = (fz, kappa, alpha, np.deg2rad(gamma_deg), vx)
        with np.errstate(all="ignore"):  # no limit checks: the two files' limits differ
            a = evaluate(F, *args, p=pi * 1e5, mode=FIT_MODE)[name]
            b = evaluate(T, *args, p=pi * 1e5, mode=FIT_MODE)[name]
        out.append(_error(name, a, b, FORCE_TOLERANCE_PCT,
                          f"{len(rows)} MF points of the {quantity} stages"))
    for name, quantity in STIFFNESSES.items():
        rows = points[(~mf) & (q == quantity)]
        fz_rows = rows["Fz_N"].to_numpy(float) if not rows.empty else np.empty(0)
        pi_rows = rows["pi_bar"].to_numpy(float) if not rows.empty else np.empty(0)
        if fz_rows.size == 0 or not np.isfinite(fz_rows).any():
            continue
        fz_g, pi_g = np.meshgrid(np.linspace(np.nanmin(fz_rows), np.nanmax(fz_rows), GRID[0]),
                                 np.linspace(np.nanmin(pi_rows), np.nanmax(pi_rows), GRID[1]))
        fz_g, p_g = fz_g.ravel(), pi_g.ravel() * 1e5
        where = (f"{GRID[0]} x {GRID[1]} grid over the {quantity} points "
                 f"({np.nanmin(fz_rows):.0f}-{np.nanmax(fz_rows):.0f} N, "
                 f"{np.nanmin(pi_rows):g}-{np.nanmax(pi_rows):g} bar)")
        if name == "CMz":
            a, b = cmz(F, fz_g, p_g), cmz(T, fz_g, p_g)
        else:
            zeros = np.zeros_like(fz_g)
            v = np.full_like(fz_g, FLATPLANK_SPEED)
            with np.errstate(all="ignore"):
                a = evaluate(F, fz_g, zeros, zeros, zeros, v, p=p_g, mode=FIT_MODE)[_OUTPUT[name]]
                b = evaluate(T, fz_g, zeros, zeros, zeros, v, p=p_g, mode=FIT_MODE)[_OUTPUT[name]]
        out.append(_error(name, np.asarray(a, float), np.asarray(b, float),
                          STIFFNESS_TOLERANCE_PCT, where))
    return TruthComparison(tuple(out))
