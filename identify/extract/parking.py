"""CMz from parking runs: the slope dMz/dpsi of the linear part around psi = 0.

The standing tyre is steered 0 -> +R -> -R -> +R. The first branch starts from zero torque
(virgin curve, steeper near psi = 0) and is not used; every later branch that crosses (or
ends at) psi = 0 gives a linear window around the crossing (searched inside a torque band of
:attr:`Thresholds.parking_band` of the saturated torque, then shrunk until a line explains it
within the noise). CMz is the common slope of all windows, each with its own
offset (the loop's hysteresis shifts the branches up and down).
"""
from __future__ import annotations

import numpy as np

from identify.extract.diagnostics import Flag, Part, RunDiagnostic
from identify.extract.flags import Thresholds, cell_means, condition_flags, stick_slip_score
from identify.extract.linear import line_fit, linear_window, noise_sigma, smooth
from identify.extract.runs import RunData

__all__ = ["branches", "parking_run", "extract_parking"]


def branches(psi: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1) over which the turn-table angle moves one way."""
    step = np.sign(np.diff(psi))
    moving = np.flatnonzero(step != 0)
    if moving.size == 0:
        return []
    step = step[moving]
    turns = moving[1:][step[1:] != step[:-1]]
    edges = np.concatenate([[moving[0]], turns, [psi.size - 1]])
    return [(int(a), int(b) + 1) for a, b in zip(edges[:-1], edges[1:]) if b - a >= 4]


def _branch_window(psi, mz, height: float, sigma: float, th: Thresholds):
    """Linear window around psi = 0 on one branch (psi ascending); None if it fails.

    ``height`` [N m] is the saturated torque measured from the zero crossing; the window is
    searched where the smoothed torque stays within ``th.parking_band * height`` of it.
    ``sigma`` [N m] is the run's noise level.
    """
    ms = smooth(mz, 0.02)
    m0 = float(np.interp(0.0, psi, ms))
    outside = np.flatnonzero(np.abs(ms - m0) > th.parking_band * height)
    zero = int(np.searchsorted(psi, 0.0))
    before, after = outside[outside < zero], outside[outside >= zero]
    lo = int(before[-1]) + 1 if before.size else 0
    hi = int(after[0]) if after.size else psi.size
    if hi - lo < 5:  # too coarse a sampling to tell a line from the bends
        return None
    fit = linear_window(psi[lo:hi], mz[lo:hi], sigma, min_points=5, min_fraction=0.3,
                        must_contain=0.0)
    return line_fit(psi, mz, lo, hi) if fit is None else line_fit(psi, mz, lo + fit.i0,
                                                                  lo + fit.i1)


def _saturated_height(psi, mz, parts) -> float:
    """Torque from the zero crossing to the plateau the branches end on [N m].

    Measured at the end of each branch that crosses zero and ends far from it (the start of a
    branch carries the reversal, where the hysteresis offset flips).
    """
    heights, reach = [], 0.5 * np.abs(psi).max()
    for a, b in parts:
        p, ms = psi[a:b], smooth(mz[a:b], 0.02)
        if abs(p[-1]) < reach or not (p.min() < 0.0 < p.max()):
            continue
        order = np.argsort(p, kind="stable")
        heights.append(abs(ms[-1] - float(np.interp(0.0, p[order], ms[order]))))
    if heights:
        return float(np.median(heights))
    return 0.5 * float(np.ptp(mz))


def parking_run(psi: np.ndarray, mz: np.ndarray, th: Thresholds) -> dict:
    """CMz, windows and stick-slip score of one parking run.

    Parameters
    ----------
    psi : numpy.ndarray
        Turn-table angle [rad].
    mz : numpy.ndarray
        Aligning torque [N m].
    th : Thresholds
        Band and stick-slip settings.

    Returns
    -------
    dict
        ``cmz`` [N m/rad] (NaN when no branch reaches zero), ``se`` [N m/rad], ``fits`` (one
        :class:`LineFit` per branch used, indices within that branch), ``log10p`` and
        ``amplitude`` of the stick-slip test (most significant saturated stretch,
        Bonferroni-corrected), ``height`` (saturated torque [N m]).
    """
    parts = branches(psi)
    virgin = bool(parts) and abs(psi[parts[0][0]]) < 0.05 * np.abs(psi).max()
    height = _saturated_height(psi, mz, parts[1:] if virgin else parts)
    # the noise is one level over the run: estimate it from all of it
    sigma = noise_sigma(mz, floor=1e-6 * height)
    used, scores = [], []
    for k, (a, b) in enumerate(parts):
        ms = smooth(mz[a:b], 0.02)
        sat = np.flatnonzero(np.abs(ms - ms[-1]) <= 0.1 * max(np.ptp(ms), 1e-300))
        if sat.size:
            stretch = slice(a + int(sat[0]), b)
            scores.append(stick_slip_score(psi[stretch], mz[stretch], height))
        p, m = psi[a:b], mz[a:b]
        if p[-1] < p[0]:
            p, m = p[::-1], m[::-1]
        if (k == 0 and virgin) or not (p[0] <= 0.0 <= p[-1]) or p[0] == p[-1]:
            continue
        fit = _branch_window(p, m, height, sigma, th)
        if fit is not None:
            used.append((p[fit.i0:fit.i1], m[fit.i0:fit.i1], fit))
    log10p, amp = min(scores, default=(0.0, 0.0))
    log10p = min(0.0, log10p + float(np.log10(max(len(scores), 1))))
    out = {"cmz": np.nan, "se": np.nan, "fits": [u[2] for u in used], "log10p": log10p,
           "amplitude": amp, "height": height}
    if not used:
        return out
    dx = [p - p.mean() for p, _, _ in used]
    dy = [m - m.mean() for _, m, _ in used]
    sxx = float(sum((d * d).sum() for d in dx))
    cmz = float(sum((d * e).sum() for d, e in zip(dx, dy)) / sxx)
    sse = float(sum(((e - cmz * d) ** 2).sum() for d, e in zip(dx, dy)))
    n = sum(d.size for d in dx)
    out.update(cmz=cmz, se=float(np.sqrt(sse / max(n - 1 - len(used), 1) / sxx)),
               r2=1.0 - sse / float(sum((e * e).sum() for e in dy)),
               rmse=float(np.sqrt(sse / n)), n=n)
    return out


def extract_parking(runs: list[RunData], th: Thresholds) -> Part:
    """CMz per pressure x load cell: the mean over the start positions.

    Parameters
    ----------
    runs : list of RunData
        Parking runs.
    th : Thresholds
        Flag thresholds and window settings.
    """
    diags, flags = [], []
    cells: dict[tuple[float, float], list[tuple[float, float]]] = {}
    for run in runs:
        res = parking_run(run.ch["psi"], run.ch["Mz"], th)
        mine = condition_flags(run, th)
        if res["log10p"] <= th.stick_slip_log10p and \
                res["amplitude"] >= th.stick_slip_amplitude:
            mine.append(Flag(run.run, run.test, "stick_slip",
                             f"stick-slip in the saturated torque: oscillation of "
                             f"{100 * res['amplitude']:.1f} % of the saturation torque "
                             f"(p = 1e{res['log10p']:.0f})"))
        flags += mine
        fits = res["fits"]
        if np.isfinite(res["cmz"]):
            cells.setdefault(run.cell, []).append((res["cmz"], res["se"]))
        window = (min(f.lo for f in fits), max(f.hi for f in fits)) if fits else None
        diags.append(RunDiagnostic(
            run.run, run.test, "CMz", run.p_bar, run.load_N, run.start, res["cmz"], window,
            "rad", res.get("n", 0), res.get("r2", np.nan), res.get("rmse", np.nan),
            tuple(f.flag for f in mine),
            {"slope_se": res["se"], "branches": [[f.lo, f.hi] for f in fits],
             **({} if fits else {"error": "no branch has 5 samples in its linear part "
                                          "around psi = 0"}),
             "saturation_Nm": res["height"], "stick_slip_log10p": res["log10p"],
             "stick_slip_amplitude": res["amplitude"]}))
    rows, spread = cell_means("parking", "CMz", cells, th)
    return Part(tuple(rows), tuple(diags), tuple(flags + spread))
