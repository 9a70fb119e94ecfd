"""Segmentation of the real TTC sets beside the project (``../shared/realdata``): every set
point that holds sweeps is one level, and every full sweep a sweep.

The set points are the TTC's, in US units: pressures 8-16 psi, loads 50-450 lbf, speeds 15,
25 and 45 mph, camber steps of 1 or 2 deg. The found level is the median of the sweeps'
medians: the pressure of a warm tyre sits up to 2 % above its cold set point, and a load up
to 5 % off (the load control lags the side force and over- or undershoots at high slip).
Skipped where the real sets are absent."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from identify.io.trailer.files import read_trailer
from identify.segment import segment_trailer
from tests.realdata import REALDATA, require_realdata

pytestmark = pytest.mark.trials

PSI, LBF, MPH = 6894.757, 4.448222, 0.44704
R2 = "ttc_r2_b1052_hoosier_20.5x7.0-13"
R6 = "ttc_r6_deid_lateral_longitudinal"


def _table(folder: str, *stems: str) -> pd.DataFrame:
    require_realdata()
    files = sorted((REALDATA / folder).glob("*.mat"))
    files = [f for f in files if not stems or f.stem in stems]
    if not files:
        pytest.skip(f"{folder} has no {stems or 'files'}")
    return pd.concat([read_trailer(f) for f in files], ignore_index=True)


def _near(found, want, rel=None, atol=None) -> None:
    found, want = np.asarray(found, float), np.asarray(want, float)
    assert found.shape == want.shape, (found, want)
    tol = rel * want if rel is not None else atol
    assert np.all(np.abs(found - want) <= tol), (found, want)


def _kinds(result, run: str) -> list[str]:
    return [g.kind for g in result.segmentation.segments
            if g.run == run and g.kind not in ("transition", "steady")]


def test_round2_pressure_run_holds_five_pressures():
    """Run 26 alone: a cornering sweep at 150 and at 350 lbf at each of 8, 10, 12, 14, 16 psi
    (and two run-in sweeps at 250 lbf): five pressure levels, three load levels."""
    result = segment_trailer(_table(R2, "B1052run26"))
    seg = result.segmentation
    p = np.array(seg.level_values("p"))
    assert p.size == 5 and np.all((p >= np.array([8, 10, 12, 14, 16]) * PSI) &
                                  (p <= 1.02 * np.array([8, 10, 12, 14, 16]) * PSI)), p
    _near(seg.level_values("Fz"), np.array([150, 250, 350]) * LBF, rel=0.05)
    assert _kinds(result, "B1052run26").count("sweep") == 12


def test_round2_camber_run_holds_five_cambers_and_loads():
    """Run 25 alone: 12 psi, camber 0-4 deg in 1 deg steps, one sweep at each of 50, 150,
    250, 350, 450 lbf per camber: every one of the 27 sweeps (two run-in) whole."""
    result = segment_trailer(_table(R2, "B1052run25"))
    seg = result.segmentation
    _near(np.rad2deg(seg.level_values("gamma")), [0, 1, 2, 3, 4], atol=0.1)
    _near(seg.level_values("Fz"), np.array([50, 150, 250, 350, 450]) * LBF, rel=0.05)
    assert len(seg.level_values("p")) == 1
    assert _kinds(result, "B1052run25") == ["warmup"] + ["sweep"] * 27


def test_round2_set_levels_and_drive_brake_sweeps():
    """The whole round-2 set: five pressures, five loads, five cambers; each drive/brake run
    holds ten slip-ratio sweeps, none partial."""
    result = segment_trailer(_table(R2))
    seg = result.segmentation
    assert len(seg.level_values("p")) == 5
    _near(seg.level_values("Fz"), np.array([50, 150, 250, 350, 450]) * LBF, rel=0.05)
    assert len(seg.level_values("gamma")) == 5
    for run in ("B1052run33", "B1052run34"):
        assert _kinds(result, run) == ["sweep"] * 10


def test_round6_set_levels():
    """Round 6: 8 and 12 psi; 50-250 lbf in 50 lbf steps (the lateral run sweeps 100 lbf,
    the longitudinal one does not); camber 0, 2, 4 deg; 15, 25, 45 mph; set slip angles 0,
    3, 6 deg; every sweep whole."""
    result = segment_trailer(_table(R6))
    seg = result.segmentation
    _near(seg.level_values("p"), np.array([8, 12]) * PSI, rel=0.02)
    _near(seg.level_values("Fz"), np.array([50, 100, 150, 200, 250]) * LBF, rel=0.05)
    _near(np.rad2deg(seg.level_values("gamma")), [0, 2, 4], atol=0.1)
    _near(seg.level_values("Vx"), np.array([15, 25, 45]) * MPH, rel=0.02)
    _near(np.abs(np.rad2deg(seg.level_values("alpha"))), [0, 3, 6], atol=0.1)
    kinds = [g.kind for g in seg.segments if g.kind not in ("transition", "steady")]
    assert kinds == ["sweep"] * len(kinds) and len(kinds) == 42 + 72


def test_round2_pressure_run_keeps_the_cool_starts_of_its_sweeps():
    """Run 26 changes the pressure between pairs of sweeps: the tread cools towards ambient
    (21 degC) while the tyre is lifted, and each hard sweep starts at about 20 degC and heats
    its tread to about 50. That cool start is the run's working range, not a cold tread: the
    cold-tread filter removes at most the few samples at about ambient (under 5 % of the
    sweeps'), and every sweep keeps its small slip angles (where the cornering stiffness and
    the pneumatic trail are measured)."""
    result = segment_trailer(_table(R2, "B1052run26"))
    seg = result.segmentation
    assert {f.name: f.removed for f in seg.filters}["cold tread"] < 0.05 * seg.in_sweeps
    kept = result.table
    for k in np.unique(kept["segment"]):
        alpha = np.rad2deg(kept.loc[kept["segment"] == k, "alpha"].abs())
        assert (alpha < 1.0).sum() >= 20, k
