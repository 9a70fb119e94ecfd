"""The MF slip pages an engineer asked for (issue 18): one y-scale across the pressure panels,
one legend entry per load, no vertical bars of camber sweeps on the slip-angle pages, measured
combined-slip markers on the friction ellipse; and the MF stage page's legend.

The measured-vs-model rows are generated from the default tyre on a trailer-like design: pure
alpha and kappa sweeps at gamma = 0, alpha sweeps at gamma = +-4 deg, camber sweeps at
alpha = 0 and 4 deg, and combined kappa sweeps at alpha = 3 and 6 deg, at 2 pressures x 3
loads.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from identify.core.tyre import TyreInfo
from identify.fit.result import FitResult
from identify.fit.run import FitRun, Provenance
from identify.io.fitdir import FitDir
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.report.fit_pages import fit_pages
from identify.report.slip_pages import mf_slip_pages, slip_pages
from identify.simulate.default_tyre import default_tir_path

PRESSURES = (1.9, 3.0)
LOADS = (3000.0, 5000.0, 7000.0)


def _rows(P) -> pd.DataFrame:
    d = np.deg2rad
    sweeps = []  # (form, quantity list, kappa, alpha, gamma) per sweep, arrays of one length
    a = d(np.linspace(-12, 12, 49))
    z = np.zeros_like(a)
    for g in (0.0, -4.0, 4.0):
        sweeps.append(("Fy0", ("Fy", "Mz"), z, a, np.full_like(a, d(g))))
    k = np.linspace(-0.3, 0.3, 41)
    sweeps.append(("Fx0", ("Fx",), k, np.zeros_like(k), np.zeros_like(k)))
    g = d(np.linspace(-8, 8, 33))
    for a0 in (0.0, 4.0):
        sweeps.append(("Fy0", ("Fy", "Mz"), np.zeros_like(g), np.full_like(g, d(a0)), g))
    kc = np.linspace(-0.25, 0.25, 41)
    for a0 in (3.0, 6.0):
        sweeps.append(("combined", ("Fx", "Fy"), kc, np.full_like(kc, d(a0)),
                       np.zeros_like(kc)))
    frames = []
    for p in PRESSURES:
        for fz in LOADS:
            for form, quantities, kappa, alpha, gamma in sweeps:
                n = kappa.size
                out = evaluate(P, np.full(n, fz), kappa, alpha, gamma, np.full(n, 16.7),
                               p=np.full(n, p * 1e5), mode=211)
                for q in quantities + (("Mx",) if form == "Fy0" else ()):
                    frames.append(pd.DataFrame({
                        "relation": "MF", "form": "Mx" if q == "Mx" else form, "quantity": q,
                        "unit": "N", "pi_bar": p, "Fz_N": fz, "gamma_deg": np.rad2deg(gamma),
                        "alpha_rad": alpha, "kappa": kappa, "Vx_mps": 16.7,
                        "measured": out[q] * 1.002, "model": out[q]}))
    return pd.concat(frames, ignore_index=True)


@pytest.fixture(scope="module")
def fd() -> FitDir:
    P = read_tir(default_tir_path()).params()
    points = _rows(P)
    tyre = TyreInfo("slip-test", 250000.0, 5000.0, 0.3205, "simulated", "225/50 R17")
    fy0 = points[points["form"] == "Fy0"]
    result = FitResult("MF", "Fy0", "wls", {"PKY1": P["PKY1"]}, ("PKY1",), {"PKY1": 0.1},
                       {"PKY1": (-100.0, -1.0)}, (), (), 0.2, {1.9: 0.2, 3.0: 0.2}, 1.0,
                       len(fy0), True, "ok", 1, 1, {}, fy0["model"].to_numpy(),
                       fy0["measured"].to_numpy(), fy0["pi_bar"].to_numpy())
    run = FitRun(tyre, Provenance("0", "", "", 0, None), (result,), {}, 61, "slip-test.tir")
    return FitDir(Path("."), run, points, P)


def test_slip_pages_share_y_limits_one_legend_entry_per_load(fd):
    pages, notes = mf_slip_pages(fd)
    assert [p.title.split(" (")[0] for p in pages] == [
        "Fy - alpha", "Fx - kappa", "Mz - alpha", "Mx - gamma", "Friction ellipse"]
    drawn = slip_pages(fd, pages)
    for (title, fig), sp in zip(drawn, pages):
        axes = [ax for ax in fig.axes if ax.get_title().endswith("bar")]
        assert len(axes) == len(PRESSURES), title
        assert len({ax.get_ylim() for ax in axes}) == 1, title  # one y-scale
        labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
        assert [x for x in labels if x.startswith("Fz ")] == [f"Fz {v:.0f} N" for v in LOADS]
        if sp.ellipse:
            assert len({ax.get_xlim() for ax in axes}) == 1
            assert "measured (combined slip)" in labels
            assert sp.alphas_deg == (3.0, 6.0)  # the measured combined slip angles
            # both combined sweeps (41 kappa each) but kappa = 0, which is not combined slip
            assert all(pt[0].size == 80 for panel in sp.panels for pt in panel.points)


def test_camber_sweeps_are_no_vertical_bars_on_slip_angle_pages(fd):
    pages, _ = mf_slip_pages(fd)
    fy = pages[0]
    for panel in fy.panels:
        for x, _ in panel.points:
            # the gamma = 0 alpha sweep only, none repeated (the camber sweeps at alpha = 0 and
            # 4 deg pass gamma = 0 too, and would stack there; the alpha sweep's own points at
            # those two angles share their operating point and go with them)
            # (the combined sweeps' kappa = 0 points at 3 and 6 deg are pure side slip: kept)
            values, counts = np.unique(np.round(x, 6), return_counts=True)
            assert values.size == 47 and x.size == 49 and counts.max() <= 2
    mx = pages[3]
    for panel in mx.panels:
        for x, _ in panel.points:  # the camber sweep at alpha = 0 only
            assert x.size >= 30 and np.unique(np.round(x, 6)).size == x.size


def test_mf_stage_page_legend_has_one_entry_per_load_and_camber_level(fd):
    (title, fig), *_ = fit_pages(fd, fd.run.results[0])[0]
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["1.9 bar", "3 bar", "Fz [N] 3000", "Fz [N] 5000", "Fz [N] 7000",
                      "gamma [deg] -4", "gamma [deg] 0", "gamma [deg] 4"]
    # the camber sweeps at a fixed slip angle are not in the slip-angle panel (their own panel
    # draws them against camber)
    xs = np.concatenate([line.get_xdata() for line in ax.get_lines()
                         if line.get_linestyle() == "None"])
    _, counts = np.unique(np.round(xs, 6), return_counts=True)
    # without the camber sweeps (33 points each at alpha = 0 and 4 deg, per pressure and load)
    # at most one point per pressure, load, camber level and quantity shares a slip angle
    assert counts.max() <= 2 * 3 * 3 * 2 and xs.size >= 1600
