"""Camber thrust and torques Fy_gamma, Mz_gamma, Mx_gamma: camber run minus 0-deg reference.

Each camber run (free rolling at gamma) has its 0-deg reference of the same pressure, load and
start position subtracted, which removes ply-steer, conicity and non-uniformity. The lateral
force difference builds up as Fss (1 - exp(-x/sigma)); the fit of Fy gives sigma, and the steady
Mz and Mx differences follow from the same build-up shape (a one-parameter linear fit, which
averages the noisier moments over the whole run). The asymmetry flag compares |Fy_gamma| at
-gamma and +gamma per pressure x load cell, pooled over the camber angles.
"""
from __future__ import annotations

import math

import numpy as np

from identify.extract.diagnostics import Flag, Part, RunDiagnostic, row
from identify.extract.flags import Thresholds, condition_flags, spread_flag
from identify.extract.relaxation import difference, fit_build_up, pair_with_reference
from identify.extract.runs import RunData, cell_label

__all__ = ["QUANTITIES", "camber_run", "asymmetry", "extract_camber"]

#: Characteristic -> channel of the difference.
QUANTITIES = {"Fy_gamma": "Fy", "Mz_gamma": "Mz", "Mx_gamma": "Mx"}


def camber_run(run: RunData, refs: list[RunData]) -> dict:
    """Steady Fy, Mz, Mx differences of one camber run against its reference(s).

    Returns
    -------
    dict
        ``values`` (quantity -> steady difference [N or N m]), ``errors`` (their standard
        errors, the moments' including the uncertainty of the build-up length), ``fit`` (the
        Fy build-up fit of :func:`fit_build_up`) and ``distance`` [m].
    """
    x, fy = difference(run, refs, "Fy")
    fit = fit_build_up(x, fy)
    values, errors = {"Fy_gamma": fit["fss"]}, {"Fy_gamma": fit["fss_se"]}
    sigma = fit["sigma"]
    for q in ("Mz_gamma", "Mx_gamma"):
        _, y = difference(run, refs, QUANTITIES[q])
        if not math.isfinite(sigma):
            values[q] = errors[q] = math.nan
            continue
        # steady value for the build-up shape of sigma, sigma - d and sigma + d
        shapes = -np.expm1(-x[None, :] / (sigma * np.array([1.0, 0.999, 1.001]))[:, None])
        steady = (shapes @ y) / (shapes * shapes).sum(axis=1)
        res = y - steady[0] * shapes[0]
        var = float(res @ res) / max(y.size - 1, 1) / float(shapes[0] @ shapes[0])
        # the shape is itself an estimate: add its share of the uncertainty
        slope = (steady[2] - steady[1]) / (0.002 * sigma)
        values[q] = float(steady[0])
        errors[q] = math.sqrt(var + (slope * fit["sigma_se"]) ** 2)
    return {"values": values, "errors": errors, "fit": fit, "distance": float(x.max())}


def asymmetry(values: dict[float, float]) -> float:
    """Pooled relative asymmetry of a camber characteristic [-].

    ``values`` maps gamma [deg] -> value; pairs of +gamma and -gamma give
    sum(|F(-g)| - |F(+g)|) / sum((|F(-g)| + |F(+g)|)/2), positive when -gamma is stronger.
    NaN without a pair.
    """
    pairs = [(abs(values[-g]), abs(values[g])) for g in values if g > 0 and -g in values]
    pairs = [(a, b) for a, b in pairs if math.isfinite(a) and math.isfinite(b)]
    if not pairs:
        return math.nan
    neg, pos = np.array(pairs).T
    return float((neg - pos).sum() / (0.5 * (neg + pos)).sum())


def extract_camber(runs: list[RunData], th: Thresholds) -> Part:
    """Fy_gamma, Mz_gamma, Mx_gamma per pressure x load x camber cell (mean over starts).

    Parameters
    ----------
    runs : list of RunData
        Camber runs, 0-deg references included.
    th : Thresholds
        Flag thresholds.
    """
    rows, diags, flags = [], [], []
    cells: dict[tuple[float, float, float], list[dict]] = {}
    for run in runs:
        flags += condition_flags(run, th)
    for run, refs in pair_with_reference(runs, lambda r: abs(r.gamma_deg) < 0.05):
        if not refs:
            diags.append(RunDiagnostic(run.run, run.test, "Fy_gamma", run.p_bar, run.load_N,
                                       run.start, math.nan,
                                       extra={"error": "no 0-deg reference"}))
            continue
        res = camber_run(run, refs)
        fit = res["fit"]
        lengths = res["distance"] / fit["sigma"] if fit["sigma"] > 0 else math.nan
        mine = [] if lengths >= th.short_run else [Flag(
            run.run, run.test, "short_run", f"rolled {lengths:.1f} relaxation lengths "
            f"(< {th.short_run:g}): steady camber forces extrapolated by the exponential fit")]
        flags += mine
        cells.setdefault((run.p_bar, run.load_N, run.gamma_deg), []).append(res)
        diags.append(RunDiagnostic(
            run.run, run.test, "Fy_gamma", run.p_bar, run.load_N, run.start,
            res["values"]["Fy_gamma"], (0.0, res["distance"]), "m", fit["n"], fit["r2"],
            fit["rmse"], tuple(f.flag for f in mine),
            {"gamma_deg": run.gamma_deg, "reference": [r.run for r in refs],
             "sigma_m": fit["sigma"], "relaxation_lengths": lengths,
             "Mz_gamma_Nm": res["values"]["Mz_gamma"], "Mx_gamma_Nm": res["values"]["Mx_gamma"],
             "se": res["errors"]}))
    by_cell: dict[tuple[float, float], dict[float, float]] = {}
    for (p, fz, g), results in sorted(cells.items()):
        for q in QUANTITIES:
            vals = [r["values"][q] for r in results]
            rows.append(row(q, p, fz, float(np.nanmean(vals)), gamma_deg=g))
            found = spread_flag(cell_label("camber", p, fz) + f"_g{g:g}", "camber", q, vals,
                                [r["errors"][q] for r in results], th)
            flags += [found] if found else []
        by_cell.setdefault((p, fz), {})[g] = rows[-3]["value"]
    for (p, fz), values in sorted(by_cell.items()):
        a = asymmetry(values)
        if abs(a) > th.asymmetry:
            side = "-gamma" if a > 0 else "+gamma"
            flags.append(Flag(cell_label("camber", p, fz), "camber", "asymmetry",
                              f"|Fy_gamma| is {100 * abs(a):.1f} % larger at {side} than at the "
                              f"opposite camber (threshold {100 * th.asymmetry:.0f} %): hub "
                              "calibration or an asymmetric carcass?"))
    return Part(tuple(rows), tuple(diags), tuple(flags))
