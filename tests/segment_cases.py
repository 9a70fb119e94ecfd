"""Checks of a segmentation against the truth of a simulated TTC session (tests and trials)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.io.trailer.files import read_trailer
from identify.segment import SegmentedTable, segment_trailer

#: Largest distance of a found level from its set point [SI]: 2 % of the load; 4 % of the
#: pressure (the level is the median of the warm segments: the gas warms a few kPa above the
#: cold set pressure); 0.2 deg; 0.3 m/s.
TOLERANCE = {"Fz": lambda v: 0.02 * v, "p": lambda v: 0.04 * v,
             "gamma": lambda v: np.deg2rad(0.2), "alpha": lambda v: np.deg2rad(0.2),
             "Vx": lambda v: 0.3}


def set_points(truth: dict) -> dict[str, list[float]]:
    """The set points of every condition channel in a session [SI, ISO-W]."""
    plan = truth["plan"]
    tests = {r["test"] for r in truth["runs"]}
    cambers = set(plan["cornering_cambers_deg"])
    if "drive_brake" in tests:
        cambers |= set(plan["drive_cambers_deg"])
    out = {"Fz": sorted(plan["loads_N"]), "p": sorted(plan["pressures_Pa"]),
           "gamma": sorted(np.deg2rad(sorted(cambers))), "Vx": [plan["speed_mps"]]}
    out["alpha"] = (sorted(np.deg2rad(plan["drive_slip_angles_deg"]))
                    if "drive_brake" in tests else [])
    return out


def segmented(session) -> tuple[SegmentedTable, pd.DataFrame]:
    """Load the session's .mat files and segment them."""
    table = pd.concat([read_trailer(f) for f in session.files if f.suffix == ".mat"],
                      ignore_index=True)
    return segment_trailer(table), table


def check(session, result: SegmentedTable | None = None) -> SegmentedTable:
    """Assert the acceptance: levels = set points (all, none extra); every programmed sweep
    found once at its levels; no warm-up or cold sample kept; transitions < 1 %. ``result``:
    the session's :func:`segmented` table when the caller has it already."""
    if result is None:
        result, _ = segmented(session)
    seg = result.segmentation
    for channel, want in set_points(session.truth).items():
        got = seg.level_values(channel)
        assert len(got) == len(want), (channel, got, want)
        for g, w in zip(got, want):
            assert abs(g - w) <= TOLERANCE[channel](abs(w)), (channel, got, want)
    p_drift = np.array(seg.level_values("p")) - np.array(set_points(session.truth)["p"])
    assert (p_drift > 0).all()  # the pressure rises with the tyre's temperature
    # the generator's sweeps work the tread at 55 degC, ambient 25: a sample less than halfway
    # up (40 degC) is cold; the rule's halfway mark is from the run's medians (0.5 K slack)
    cold = session.truth.get("cold_K", 273.15 + 39.5)
    assert (result.table["T_tread_centre"] >= cold).all()
    assert {f.name: f.removed for f in seg.filters}["cold tread"] > 0
    for run in session.truth["runs"]:
        truth_segs = run["segments"]
        starts = np.array([s["t_start"] for s in truth_segs])
        kinds = np.array([s["kind"] for s in truth_segs])
        kept = result.table[result.table["run"] == run["stem"]]
        where = kinds[np.searchsorted(starts, kept["t"].to_numpy(), side="right") - 1]
        assert not np.isin(where, ["warmup", "start", "pressure_change"]).any()
        assert (where == "transition").mean() < 0.01
        groups: dict = {}
        for s in truth_segs:
            if s["kind"] == "sweep":
                key = (s["block"], s["gamma_deg"], s["alpha_deg"], s["fz_set"])
                groups.setdefault(key, []).append(s)
        found = [g for g in seg.segments if g.run == run["stem"] and g.kind == "sweep"]
        assert len(found) == len(groups)
        for (_, gamma, alpha, fz), parts in groups.items():
            t0, t1 = parts[0]["t_start"], parts[-1]["t_end"]
            (g,) = [g for g in found if g.t_start < t1 and g.t_end > t0]
            values = {c: seg.levels[c][k].value for c, k in g.levels.items()}
            assert abs(values["Fz"] - fz) <= TOLERANCE["Fz"](fz)
            assert abs(values["gamma"] - np.deg2rad(gamma)) <= TOLERANCE["gamma"](0)
            assert abs(values["p"] - parts[0]["p_set"]) <= TOLERANCE["p"](parts[0]["p_set"])
            assert g.sweep == ("alpha" if run["test"] == "cornering" else "kappa")
            if g.sweep == "kappa":
                assert abs(values["alpha"] - np.deg2rad(alpha)) <= TOLERANCE["alpha"](0)
    return result
