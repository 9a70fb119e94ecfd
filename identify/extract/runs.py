"""Flatplank runs as arrays, with the conditions each was run at.

The tidy Flatplank table holds every run one sample per row; extraction works on one run at a
time, so :func:`collect_runs` cuts it into :class:`RunData` (numpy arrays per channel) and
attaches the run's conditions: the manifest's declared values where given, otherwise what the
channels show (median load, camber, slip angle) or the project's run-name convention
(``<test>_p<bar*100>_fz<N>_s<start>``).
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
import pandas as pd

__all__ = ["RunData", "collect_runs", "cell_label", "CHANNELS"]

#: Tidy-table columns carried into :class:`RunData` (SI, ISO-W).
CHANNELS = ("t", "plank_x", "wheel_angle", "psi", "hub_z", "gamma", "alpha",
            "Fx", "Fy", "Fz", "Mx", "My", "Mz")
_NAME = re.compile(r"_p(?P<p>\d+)_fz(?P<fz>\d+)(?:_s(?P<s>\d+))?")


@dataclass(frozen=True, eq=False)
class RunData:
    """One Flatplank run: its channels and conditions.

    Attributes
    ----------
    run, test : str
        Run id and test type.
    p_bar : float
        Inflation pressure [bar] (declared, or from the run name).
    load_N : float
        Set load [N]: declared ``load_N``, else the median contact Fz rounded to 50 N.
    start : int
        Start position on the circumference (0 when unknown).
    gamma_deg, alpha_deg : float
        Camber and slip angle [deg]: declared, else the median of the channel.
    declared : mapping
        The manifest's ``conditions`` of the run, as given.
    ch : mapping of str to numpy.ndarray
        Channels (:data:`CHANNELS`) [SI].
    pressure_source : str
        ``"declared"`` or ``"name"`` (from the run id).
    """

    run: str
    test: str
    p_bar: float
    load_N: float
    start: int
    gamma_deg: float
    alpha_deg: float
    declared: Mapping[str, float]
    ch: Mapping[str, np.ndarray] = field(repr=False)
    pressure_source: str = "declared"

    def __post_init__(self) -> None:
        object.__setattr__(self, "declared", MappingProxyType(dict(self.declared)))
        object.__setattr__(self, "ch", MappingProxyType(dict(self.ch)))

    @property
    def cell(self) -> tuple[float, float]:
        """(pressure [bar], load [N]): the characteristic-table cell of the run."""
        return (self.p_bar, self.load_N)


def cell_label(test: str, p_bar: float, load_N: float) -> str:
    """Name of a pressure x load cell of one test, in the run-name convention."""
    return f"{test}_p{round(p_bar * 100)}_fz{round(load_N)}"


def _pressure(run_id: str, declared: Mapping[str, float]) -> tuple[float | None, str]:
    if "pressure_Pa" in declared:
        return round(float(declared["pressure_Pa"]) / 1e5, 6), "declared"
    found = _NAME.search(run_id)
    if found:
        return int(found["p"]) / 100.0, "name"
    return None, "none"


def collect_runs(flatplank: pd.DataFrame, conditions: Mapping[str, Mapping[str, float]]
                 ) -> tuple[dict[str, list[RunData]], list[str]]:
    """Cut the tidy Flatplank table into runs, grouped by test.

    Parameters
    ----------
    flatplank : pandas.DataFrame
        Tidy Flatplank table (``identify.io``), one row per sample.
    conditions : mapping
        Run id -> declared conditions (manifest ``[[runs]].conditions``).

    Returns
    -------
    (dict, list)
        Test -> runs in table order; and the ids of runs skipped because their pressure is
        neither declared nor in the run name.
    """
    out: dict[str, list[RunData]] = {}
    skipped: list[str] = []
    if flatplank.empty:
        return out, skipped
    arrays = {c: flatplank[c].to_numpy(dtype=float) for c in CHANNELS}
    tests = flatplank["test"].to_numpy()
    for run_id, idx in flatplank.groupby("run", sort=False).indices.items():
        declared = dict(conditions.get(run_id, {}))
        p_bar, source = _pressure(str(run_id), declared)
        if p_bar is None:
            skipped.append(str(run_id))
            continue
        ch = {c: arrays[c][idx] for c in CHANNELS}
        load = declared.get("load_N")
        # undeclared: the median load to the nearest 50 N, so the runs of a cell stay together
        load = float(load) if load is not None else 50.0 * round(float(np.median(ch["Fz"])) / 50)
        found = _NAME.search(str(run_id))
        start = declared.get("start_position")
        start = int(start) if start is not None else (
            int(found["s"]) if found and found["s"] else 0)
        gamma = declared.get("gamma_deg")
        gamma = float(gamma) if gamma is not None else float(np.rad2deg(np.median(ch["gamma"])))
        alpha = declared.get("slip_angle_deg")
        alpha = float(alpha) if alpha is not None else float(np.rad2deg(np.median(ch["alpha"])))
        run = RunData(str(run_id), str(tests[idx[0]]), p_bar, load, start, gamma, alpha,
                      declared, ch, source)
        out.setdefault(run.test, []).append(run)
    return out, skipped
