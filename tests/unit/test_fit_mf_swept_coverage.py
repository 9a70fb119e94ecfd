"""Which coefficients a pure-slip stage's points identify when some of them sit at zero slip
(identify.fit.mf.stage_data.coverage_missing): the shape along the slip needs its loads,
pressures and cambers on the sweeps, the offsets (stage_specs.ZERO_SLIP) on any point.

The layout is a real TTC session's with its camber sweep and one pressure's drive/brake run
held out: cornering sweeps at zero camber, two loads and four pressures, and a drive/brake run
stepped in camber (0, 2, 4 deg) and load at one pressure, whose zero-slip-angle points enter
the pure lateral stages."""
import numpy as np
import pandas as pd

from identify.fit.coverage import mf_coverage
from identify.fit.mf.stage_data import Coverage, coverage_missing, select
from identify.fit.mf.stage_specs import NEEDS, STAGES, ZERO_SLIP

FNOMIN = 1100.0


def _session() -> pd.DataFrame:
    """Cornering: alpha -12..12 deg at 650 and 1500 N, 56/70/97/111 kPa, camber 0. Drive/brake:
    kappa -0.2..0.2 at alpha 0, 600..1800 N in five steps, camber 0/2/4 deg, 56 kPa."""
    parts = []
    alpha = np.deg2rad(np.linspace(-12, 12, 97))
    for p in (56e3, 70e3, 97e3, 111e3):
        for fz in (650.0, 1500.0):
            parts.append(pd.DataFrame({"run": "corner", "alpha": alpha, "kappa": 0.0,
                                       "gamma": 0.0, "p": p, "Fz": fz}))
    kappa = np.linspace(-0.2, 0.2, 81)
    for gamma in (0.0, 2.0, 4.0):
        for fz in (600.0, 900.0, 1200.0, 1500.0, 1800.0):
            parts.append(pd.DataFrame({"run": "drive", "alpha": 0.0, "kappa": kappa,
                                       "gamma": np.deg2rad(gamma), "p": 56e3, "Fz": fz}))
    t = pd.concat(parts, ignore_index=True)
    return t.assign(Vx=11.1, omega=40.0, Fx=1.0, Fy=1.0, Mz=1.0, Mx=1.0)


def _stage(t: pd.DataFrame, stage: str) -> tuple[pd.DataFrame, list[str]]:
    sd = STAGES[stage]
    return t.iloc[select(t, sd.selection, sd.quantity)], list(sd.coefficients)


def test_zero_slip_points_free_the_offsets_but_not_the_trail_or_the_stiffness():
    t = _session()
    pts, names = _stage(t, "Mz0")
    assert set(pts["run"]) == {"corner", "drive"}  # the drive/brake run's zero-slip points
    every = Coverage.of(pts, FNOMIN)  # counted on every point, as before: all of it free
    assert every.camber and every.loads >= 3
    held = coverage_missing(pts, STAGES["Mz0"].selection, FNOMIN, names)
    # trail and its camber shift: no sweep at a camber, sweeps at two loads
    for n in ("QBZ4", "QBZ5", "QDZ3", "QDZ4", "QEZ5", "QHZ3", "QHZ4"):
        assert held[n] == "data: no camber variation"
    for n in ("QBZ3", "QEZ3"):
        assert held[n] == "data: 2 load level(s), 3 needed"
    # the residual torque, measured at zero slip angle at every camber and load
    for n in ("QDZ6", "QDZ7", "QDZ8", "QDZ9", "QDZ10", "QDZ11", "PPZ2"):
        assert n not in held
    for n in ("QBZ2", "QDZ2", "QEZ2", "PPZ1"):  # two loads, four pressures on the sweeps
        assert n not in held
    pts, names = _stage(t, "Fy0")
    held = coverage_missing(pts, STAGES["Fy0"].selection, FNOMIN, names)
    # the camber thrust at zero slip angle is Kyg0 gamma: PKY6, PKY7; SVy's camber terms
    # trade with them there and need a sweep at a camber
    assert "PKY6" not in held and "PKY7" not in held
    for n in ("PVY3", "PVY4", "PKY3", "PKY5", "PEY4", "PEY5", "PDY3", "PPY5"):
        assert held[n] == "data: no camber variation", n


def test_fx0_counts_every_point():
    """Fx0's zero-slip-ratio points (the cornering runs, at four pressures) still count for
    all its coefficients (stage_data.SWEPT_SLIP holds the lateral selection only)."""
    t = _session()
    pts, names = _stage(t, "Fx0")
    whole = Coverage.of(pts, FNOMIN)
    assert whole.pressures == 4
    expected = {n: w for n in names if (w := whole.missing(NEEDS.get(n, ())))}
    assert coverage_missing(pts, STAGES["Fx0"].selection, FNOMIN, names) == expected
    assert "PPX1" not in expected


def test_all_points_swept_or_none_swept_count_every_point():
    t = _session()
    corner = t[t["run"] == "corner"]
    names = list(STAGES["Mz0"].coefficients)
    whole = Coverage.of(corner, FNOMIN)
    expected = {n: w for n in names if (w := whole.missing(NEEDS.get(n, ())))}
    assert coverage_missing(corner, "lateral", FNOMIN, names) == expected
    still = corner[np.abs(corner["alpha"]) < 1e-9]  # zero slip only: its own levels
    assert coverage_missing(still, "lateral", FNOMIN, ["QBZ2"]) == {}
    assert coverage_missing(t, "all", FNOMIN, ["QBZ4"]) == {}  # not a pure-slip selection


def test_the_coverage_table_and_the_fit_hold_the_same_coefficients():
    t = _session()
    cov = {c.stage: c for c in mf_coverage(t, FNOMIN, stages=("Fx0", "Fy0", "Mz0"))}
    assert "QBZ4" in cov["Mz0"].not_identifiable and "QDZ8" in cov["Mz0"].identifiable
    assert "PPX1" in cov["Fx0"].identifiable


def test_the_zero_slip_coefficients_are_pure_lateral_coefficients():
    assert ZERO_SLIP <= set(STAGES["Fy0"].coefficients) | set(STAGES["Mz0"].coefficients)
