"""CFx and CFy from locked-hub runs: the slope of force vs plank displacement.

The hub is locked and the plank moved (for CFy the tyre is turned 90 deg, and the plank travel
is the lateral displacement of the contact patch). The force rises linearly after the start-up
(slack, ringing), bends over towards the friction limit and then stick-slips. The linear window
is searched automatically inside a force band (:attr:`Thresholds.band` of the saturation force,
located on a smoothed copy of the signal so that the noise does not choose the edges) and
shrunk until a straight line explains it within the run's noise (:func:`linear_window`).

The slope keeps a small known bias. With the simulator's start-up (slack taken up over 5 % of
the saturation displacement) the band starts three take-up lengths into the run, and its top
reaches the first of the saturation bend: noise-free runs give a slope 0.21 % low (the slack
alone -0.25 %, the bend alone -0.09 %), noisy ones -0.23 % on average, 0.9 (CFx) and 1.5 (CFy)
per-cell standard errors; the noise cannot tell either end from a line. A later start or an
earlier end (bands 0.15-0.25 to 0.6-0.7) removes most of it but raises the per-cell standard
error by 10-80 %, so the worst of 15 CFx cells passes 1 % more often (4-41 % of noise seeds
instead of 2.5 %).
"""
from __future__ import annotations

import numpy as np

from identify.extract.diagnostics import Flag, Part, RunDiagnostic
from identify.extract.flags import Thresholds, cell_means, condition_flags, stick_slip_score
from identify.extract.linear import line_fit, linear_window, noise_sigma, smooth
from identify.extract.runs import RunData

__all__ = ["TESTS", "extract_stiffness", "locked_hub_run"]

#: Test type -> (characteristic, force channel).
TESTS = {"longitudinal_stiffness": ("CFx", "Fx"), "lateral_stiffness": ("CFy", "Fy")}


def locked_hub_run(x: np.ndarray, force: np.ndarray, th: Thresholds) -> dict:
    """Stiffness, window and stick-slip score of one locked-hub run.

    Parameters
    ----------
    x : numpy.ndarray
        Plank displacement from the start of the run [m].
    force : numpy.ndarray
        Contact force along the plank travel [N].
    th : Thresholds
        Band and stick-slip settings.

    Returns
    -------
    dict
        ``fit`` (:class:`LineFit` on |x|, |F|; slope = stiffness [N/m]), ``window_ok`` (the
        linear test passed), ``sigma`` (noise [N]), ``peak`` (saturation force [N]),
        ``log10p`` and ``amplitude`` of the stick-slip test.
    """
    y = force * (1.0 if np.median(force[force.size // 2:]) >= 0 else -1.0)
    u = np.abs(x)
    ys = smooth(y)
    peak = float(ys.max())

    def reach(level: float, after: int = 0) -> int:
        """First sample from ``after`` on where the smoothed force reaches ``level`` x peak."""
        return after + int(np.argmax(ys[after:] >= level * peak))

    a = reach(th.band[0])
    b = max(reach(th.band[1], a), a + 3)
    # the noise is one level over the run: estimate it from all of it
    sigma = noise_sigma(y, floor=1e-6 * peak)
    fit = linear_window(u[a:b], y[a:b], sigma, min_fraction=0.3)
    window_ok = fit is not None
    fit = line_fit(u, y, a, b) if fit is None else line_fit(u, y, a + fit.i0, a + fit.i1)
    sat = reach(0.9)
    log10p, amp = stick_slip_score(u[sat:], y[sat:], peak)
    return {"fit": fit, "window_ok": window_ok, "sigma": sigma, "peak": peak,
            "log10p": log10p, "amplitude": amp}


def extract_stiffness(runs: list[RunData], th: Thresholds) -> Part:
    """CFx or CFy per pressure x load cell: the mean slope over the start positions.

    Parameters
    ----------
    runs : list of RunData
        Locked-hub runs of one test type (``longitudinal_stiffness`` or
        ``lateral_stiffness``).
    th : Thresholds
        Flag thresholds and window settings.
    """
    if not runs:
        return Part()
    test = runs[0].test  # one test type per call
    diags, flags = [], []
    cells: dict[tuple[float, float], list[tuple[float, float]]] = {}
    for run in runs:
        quantity, channel = TESTS[run.test]
        x = run.ch["plank_x"] - run.ch["plank_x"][0]
        res = locked_hub_run(x, run.ch[channel], th)
        fit = res["fit"]
        mine = condition_flags(run, th)
        stick = res["log10p"] <= th.stick_slip_log10p and \
            res["amplitude"] >= th.stick_slip_amplitude
        if stick:
            mine.append(Flag(run.run, run.test, "stick_slip",
                             f"stick-slip after saturation: oscillation of "
                             f"{100 * res['amplitude']:.1f} % of the friction limit "
                             f"(p = 1e{res['log10p']:.0f})"))
        flags += mine
        cells.setdefault(run.cell, []).append((fit.slope, fit.slope_se))
        diags.append(RunDiagnostic(
            run.run, run.test, quantity, run.p_bar, run.load_N, run.start, fit.slope,
            (fit.lo, fit.hi), "m", fit.n, fit.r2, fit.rmse, tuple(f.flag for f in mine),
            {"slope_se": fit.slope_se, "noise_N": res["sigma"], "saturation_N": res["peak"],
             "window_force_N": [fit.intercept + fit.slope * fit.lo,
                                fit.intercept + fit.slope * fit.hi],
             "linear_test_passed": res["window_ok"], "stick_slip_log10p": res["log10p"],
             "stick_slip_amplitude": res["amplitude"]}))
    rows, spread = cell_means(test, TESTS[test][0], cells, th)
    return Part(tuple(rows), tuple(diags), tuple(flags + spread))

