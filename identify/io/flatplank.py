"""Raw Flatplank runs -> tidy tables with contact-patch (ISO-W) and wheel-centre (C) forces.

The hub transform is exactly the one of docs/procedures.md (TU Eindhoven Flatplank, thesis
appendix A): five bridges Gx1, Gx2, Gy, Gz1, Gz2 give hub forces K and moments T, which are
moved to the contact patch with the camber gamma = phi_wheel + phi_plank and the loaded radius.
It agrees with the general C -> W conversion :func:`identify.io.axes.c_to_w` (tested).
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.plausible import judge, judge_channel
from identify.core.units import same_unit, to_si, unit_problem
from identify.io.common import Problems, check_declared, check_increasing, read_numeric_csv

__all__ = ["RAW_COLUMNS", "FLATPLANK_COLUMNS", "CONSTANT_LOAD_TESTS", "hub_to_contact",
           "read_flatplank"]

#: Raw channel -> dimension (SI unless the manifest's ``units`` says otherwise).
RAW_COLUMNS: dict[str, str] = {
    "time": "time", "Gx1": "force", "Gx2": "force", "Gy": "force", "Gz1": "force",
    "Gz2": "force", "plank_x": "length", "wheel_angle": "angle", "psi": "angle",
    "hub_z": "length", "phi_wheel": "angle", "phi_plank": "angle", "loaded_radius": "length"}
_DERIVED = ("gamma", "alpha", "Fx", "Fy", "Fz", "Mx", "My", "Mz",
            "FxC", "FyC", "FzC", "MxC", "MyC", "MzC")
_CONDITION_COLUMNS = ("pressure_Pa", "load_N", "start_position")
#: Columns of the tidy Flatplank table (condition columns follow where declared).
FLATPLANK_COLUMNS = ("run", "test", "t") + tuple(RAW_COLUMNS)[1:] + _DERIVED
#: Tests run at a set vertical load (the median contact Fz is checked against ``load_N``).
CONSTANT_LOAD_TESTS = frozenset({"longitudinal_stiffness", "lateral_stiffness", "parking",
                                 "relaxation", "free_rolling", "camber", "rolling_resistance"})


def hub_to_contact(Gx1, Gx2, Gy, Gz1, Gz2, phi_wheel, phi_plank, psi, loaded_radius, *,
                   a: float, b: float) -> dict[str, np.ndarray]:
    """Hub bridge forces to contact-patch forces (ISO-W) and wheel-centre forces (TYDEX C).

    Parameters
    ----------
    Gx1, Gx2, Gy, Gz1, Gz2 : array_like
        Bridge forces [N].
    phi_wheel, phi_plank : array_like
        Hub and plank tilt [rad]; their sum is the camber angle gamma.
    psi : array_like
        Turn-table angle [rad] = slip angle alpha.
    loaded_radius : array_like
        Loaded radius r_l, positive [m].
    a, b : float
        Distance Gx1 - Gx2 bridges and Gx2 bridge - wheel-centre plane [m].

    Returns
    -------
    dict of numpy.ndarray
        ``gamma``, ``alpha`` [rad]; ``Fx, Fy, Fz`` [N], ``Mx, My, Mz`` [N m] at the contact
        patch in ISO-W; ``FxC, FyC, FzC`` [N], ``MxC, MyC, MzC`` [N m] at the wheel centre.
    """
    Gx1, Gx2, Gy, Gz1, Gz2 = (np.asarray(v, dtype=float) for v in (Gx1, Gx2, Gy, Gz1, Gz2))
    gamma = np.asarray(phi_wheel, dtype=float) + np.asarray(phi_plank, dtype=float)
    rl = np.asarray(loaded_radius, dtype=float)
    Kx, Ky, Kz = Gx1 + Gx2, Gy, Gz1 + Gz2
    Tx = Gz1 * (a + b) + Gz2 * b
    Tz = Gx1 * (a + b) + Gx2 * b
    cg, sg = np.cos(gamma), np.sin(gamma)
    zero = 0.0 * (Kx + gamma + rl)
    return {
        "gamma": gamma + zero, "alpha": np.asarray(psi, dtype=float) + zero,
        "Fx": Kx + zero,
        "Fy": -Ky * cg - Kz * sg,
        "Fz": -Ky * sg + Kz * cg,
        "Mx": -Tx + Ky * rl,
        "My": -Tz * sg + Kx * rl * cg,
        "Mz": Tz * cg + Kx * rl * sg,
        "FxC": Kx + zero, "FyC": -Ky + zero, "FzC": Kz + zero, "MxC": -Tx + zero,
        "MyC": zero.copy(), "MzC": Tz + zero,
    }


#: Raw column -> quantity of identify.core.plausible (its error band refuses the run).
_PLAUSIBLE = {"time": "time", "Gx1": "force", "Gx2": "force", "Gy": "force", "Gz1": "force",
              "Gz2": "force", "psi": "angle", "phi_wheel": "angle", "phi_plank": "angle"}


def _plausible(path: Path, raw: Mapping[str, np.ndarray], lines, problems: Problems) -> None:
    """Values no rig produces, in SI: a bridge force, an angle or a time stamp out of its
    error band, or a median time step that is not a sample interval."""
    for name, quantity in _PLAUSIBLE.items():
        found = judge_channel(quantity, raw[name])
        if found is not None and found[0].is_error:
            row = found[1]
            problems.add(path, found[0].message, key=name,
                         **({"line": lines + row} if row is not None else {}))
    t = raw["time"]
    if t.size > 1 and np.isfinite(t).all():
        finding = judge("time_step", float(np.median(np.diff(t))), what="median time step")
        if finding is not None and finding.is_error:
            problems.add(path, finding.message, key="time")


def read_flatplank(path: str | Path, *, a: float, b: float, run: str | None = None,
                   test: str = "any", units: Mapping[str, str] | None = None,
                   conditions: Mapping[str, float] | None = None,
                   problems: Problems | None = None) -> pd.DataFrame | None:
    """Read one raw Flatplank run (CSV) into the tidy table :data:`FLATPLANK_COLUMNS`.

    Parameters
    ----------
    path : str or Path
        The run's CSV file (header ``time, Gx1, ...``; ``NAME [unit]`` allowed).
    a, b : float
        Hub geometry [m] (manifest ``[rig]``).
    run, test : str, optional
        Run id (default: file stem) and test type.
    units : mapping, optional
        Column -> unit for columns not in SI.
    conditions : mapping, optional
        Declared conditions; ``pressure_Pa``, ``load_N``, ``start_position`` become columns,
        and ``load_N`` is checked against the median Fz for :data:`CONSTANT_LOAD_TESTS`.
    problems : Problems, optional
        Collector; strict by default.

    Returns
    -------
    pandas.DataFrame or None
        None when problems were found (non-strict collector).
    """
    problems = Problems.or_strict(problems)
    path = Path(path)
    units, conditions = dict(units or {}), dict(conditions or {})
    start = problems.total
    table = read_numeric_csv(path, problems, required=RAW_COLUMNS, what="column")
    for key in units:
        if key not in RAW_COLUMNS:
            problems.add(path, "the manifest gives a unit for a column that is not a "
                               f"Flatplank channel ({', '.join(RAW_COLUMNS)})", key=key)
    if table is None:
        return None
    frame, header_units, lines = table
    raw = {}
    for name, dim in RAW_COLUMNS.items():
        declared, in_file = units.get(name), header_units.get(name)
        if declared and in_file and not same_unit(declared, in_file):
            problems.add(path, f"unit conflict: the manifest says '{declared}', the file says "
                               f"'{in_file}'", key=name)
        unit = declared or in_file
        why = None if unit is None else unit_problem(unit, dim)
        if why is not None:
            problems.add(path, why, key=name)
            continue
        raw[name] = to_si(frame[name].to_numpy(), unit, dimension=dim)
    if problems.total > start:
        return None
    check_increasing(problems, path, "time", raw["time"], lines)
    _plausible(path, raw, lines, problems)
    derived = hub_to_contact(raw["Gx1"], raw["Gx2"], raw["Gy"], raw["Gz1"], raw["Gz2"],
                             raw["phi_wheel"], raw["phi_plank"], raw["psi"],
                             raw["loaded_radius"], a=a, b=b)
    if test in CONSTANT_LOAD_TESTS:
        check_declared(problems, path, "Fz", derived["Fz"], conditions.get("load_N"),
                       "contact load Fz", "N")
    out = pd.DataFrame({"t": raw.pop("time"), **raw, **derived})
    out.insert(0, "test", test)
    out.insert(0, "run", run or path.stem)
    for key in _CONDITION_COLUMNS:
        if key in conditions:
            out[key] = conditions[key]
    return out if problems.total == start else None
