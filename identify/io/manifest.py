"""The measurement folder's manifest, ``tyre.toml``, read into frozen dataclasses.

Validation collects every problem (wrong type, missing key, unknown key, bad value) so that
``mfid check`` can list them all; each names the file, the key path (``runs[2].kind``) and
what is wrong. The format is documented in docs/measurement-folder.md.
"""
from __future__ import annotations

import difflib
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from identify.core.names import name_problem
from identify.core.plausible import judge
from identify.core.serial import Serial
from identify.core.tyre import TyreInfo
from identify.core.units import unit_problem
from identify.io.axes import AXES, axes_name
from identify.io.common import Problems, cr_only, read_utf8
from identify.io.data_warning import DataWarning

__all__ = ["Manifest", "TyreInfo", "RigInfo", "RunSpec", "read_manifest", "KINDS", "TESTS",
           "MANIFEST_NAME"]

MANIFEST_NAME = "tyre.toml"
KINDS = ("trailer", "flatplank", "characteristics")
#: Test names per kind.
TESTS: dict[str, tuple[str, ...]] = {
    "flatplank": ("vertical", "longitudinal_stiffness", "lateral_stiffness", "parking",
                  "relaxation", "free_rolling", "camber", "rolling_resistance", "eigenfrequency"),
    "trailer": ("cornering", "braking_driving", "combined", "camber", "rolling_resistance"),
    "characteristics": ("eigenfrequency", "any"),
}
_NUM, _INT, _STR = "number", "integer", "string"
# key -> (type, required, check); check: "pos" (> 0), "nonneg" (>= 0) or None
_TYRE = {"id": (_STR, True, "name"), "nominal_pressure_Pa": (_NUM, True, "pos"),
         "nominal_load_N": (_NUM, True, "pos"), "unloaded_radius_m": (_NUM, True, "pos"),
         "source": (_STR, False, None), "size": (_STR, False, None),
         "description": (_STR, False, None)}
_RIG = {"hub_a_m": (_NUM, True, "nonneg"), "hub_b_m": (_NUM, True, "nonneg"),
        "name": (_STR, False, None)}
_RUN = {"id": (_STR, False, None), "file": (_STR, True, None), "kind": (_STR, True, None),
        "test": (_STR, False, None), "axes": (_STR, False, None), "units": ("table", False, None),
        "conditions": ("table", False, None)}
_CONDITIONS = {"pressure_Pa": (_NUM, False, "pos"), "load_N": (_NUM, False, "nonneg"),
               "start_position": (_INT, False, "pos"), "gamma_deg": (_NUM, False, None),
               "slip_angle_deg": (_NUM, False, None), "speed_mps": (_NUM, False, None),
               "loaded_radius_m": (_NUM, False, "pos")}
_SOURCES = ("simulated", "measured")
#: key -> (quantity of identify.core.plausible, factor to SI): checked after the conversion
_PLAUSIBLE = {"nominal_pressure_Pa": ("pressure", 1.0), "nominal_load_N": ("load", 1.0),
              "unloaded_radius_m": ("radius", 1.0), "pressure_Pa": ("pressure", 1.0),
              "load_N": ("load", 1.0), "loaded_radius_m": ("radius", 1.0),
              "speed_mps": ("speed", 1.0), "gamma_deg": ("angle", math.pi / 180.0),
              "slip_angle_deg": ("angle", math.pi / 180.0)}
_TOML_LINE = re.compile(r"at line (\d+)")


def _frozen(mapping: Mapping) -> Mapping:
    return MappingProxyType(dict(mapping))


@dataclass(frozen=True)
class RigInfo(Serial):
    """The ``[rig]`` table: Flatplank hub geometry [m]."""

    hub_a_m: float
    hub_b_m: float
    name: str = ""


@dataclass(frozen=True)
class RunSpec(Serial):
    """One ``[[runs]]`` entry: a data file, what it holds and how to read it.

    ``file`` is relative to the folder; ``units`` maps channel -> unit name; ``conditions``
    holds declared operating conditions (``pressure_Pa``, ``load_N`` ...).
    """

    id: str
    file: str
    kind: str
    test: str = "any"
    axes: str = "ISO-W"
    units: Mapping[str, str] = field(default_factory=dict)
    conditions: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "units", _frozen(self.units))
        object.__setattr__(self, "conditions", _frozen(self.conditions))


@dataclass(frozen=True)
class Manifest(Serial):
    """A folder's ``tyre.toml``: tyre, rig (or None), runs, and other top-level tables."""

    path: str
    tyre: TyreInfo
    rig: RigInfo | None
    runs: tuple[RunSpec, ...]
    extra: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "extra", _frozen(self.extra))

    @property
    def folder(self) -> Path:
        """The folder the run files are relative to."""
        return Path(self.path).parent


def _typename(value: Any) -> str:
    """``"an integer"``, ``"a string"`` ... for messages."""
    name = {bool: "boolean", int: "integer", float: "number", str: "string", dict: "table",
            list: "array"}.get(type(value), type(value).__name__)
    return f"{'an' if name[0] in 'aeiou' else 'a'} {name}"


def _table(problems: Problems, file: str, where: str, data: Any, spec: dict,
           warnings: list | None = None) -> dict | None:
    """Check one table against ``spec``; return the valid values (floats for numbers).

    Numbers are checked for plausibility (:mod:`identify.core.plausible`) in SI: an error
    band value is a problem, a warning band value goes to ``warnings`` as a DataWarning."""
    if not isinstance(data, dict):
        problems.add(file, f"expected a table, got {_typename(data)}", key=where)
        return None
    out: dict[str, Any] = {}
    prefix = f"{where}." if where else ""
    for key, value in data.items():
        if key not in spec:
            close = difflib.get_close_matches(key, list(spec), n=1)
            hint = f"did you mean '{close[0]}'?" if close else f"expected one of: {', '.join(spec)}"
            problems.add(file, f"unknown key ({hint})", key=prefix + key)
            continue
        kind, _, check = spec[key]
        ok = {_NUM: isinstance(value, (int, float)) and not isinstance(value, bool),
              _INT: isinstance(value, int) and not isinstance(value, bool),
              _STR: isinstance(value, str), "table": isinstance(value, dict)}[kind]
        if not ok:
            problems.add(file, f"expected a {kind}, got {_typename(value)} ({value!r})",
                         key=prefix + key)
            continue
        if kind == _NUM:
            try:
                value = float(value)
            except OverflowError:
                problems.add(file, f"number too large ({len(str(value))} digits)",
                             key=prefix + key)
                continue
            if value != value or value in (float("inf"), float("-inf")):
                problems.add(file, f"{value} is not allowed", key=prefix + key)
                continue
        if check == "name" and name_problem(value):
            problems.add(file, f"{name_problem(value)}: the tyre id names the fit directory, "
                               "the .tir and the report", key=prefix + key)
            continue
        if (check == "pos" and value <= 0) or (check == "nonneg" and value < 0):
            problems.add(file, f"must be {'positive' if check == 'pos' else '>= 0'}, got {value}",
                         key=prefix + key)
            continue
        if kind == _NUM and key in _PLAUSIBLE:
            quantity, factor = _PLAUSIBLE[key]
            found = judge(quantity, value * factor, what=key)
            if found is not None and found.is_error:
                problems.add(file, found.message, key=prefix + key)
                continue
            if found is not None and warnings is not None:
                warnings.append(DataWarning(file, "", "plausible", (prefix + key,), 1, 1,
                                            found.message, "kept"))
        out[key] = value
    for key, (kind, required, _) in spec.items():
        if required and key not in data:
            problems.add(file, f"missing required key ({kind})", key=prefix + key)
    return out


def read_manifest(path: str | Path, problems: Problems | None = None, *,
                  partial: bool = False, warnings: list | None = None) -> Manifest | None:
    """Read and validate ``tyre.toml``.

    Parameters
    ----------
    path : str or Path
        The manifest file.
    problems : Problems, optional
        Collector; by default a strict one (the first problem raises InputError).
    partial : bool
        With a non-strict collector: return what is valid (the good runs; NaN for bad
        ``[tyre]`` values, no rig if ``[rig]`` is bad) instead of None, so that a check can go
        on to the data files.
    warnings : list, optional
        Receives a DataWarning (kind ``"plausible"``) per value in a warning band.

    Returns
    -------
    Manifest or None
        None when problems were found (unless ``partial``) or the file is not valid TOML.
    """
    problems = Problems.or_strict(problems)
    path = Path(path)
    file = str(path)
    start = problems.total
    text = read_utf8(path, problems, missing=f"no {MANIFEST_NAME} in the folder")
    if text is None:
        return None
    if cr_only(text):  # classic Mac OS line ends: TOML wants LF, the lines are the same
        text = text.replace("\r", "\n")
    try:
        data = tomllib.loads(text)
    except RecursionError:
        problems.add(file, "invalid TOML: nested too deeply")
        return None
    except tomllib.TOMLDecodeError as exc:
        match = _TOML_LINE.search(str(exc))
        problems.add(file, f"invalid TOML: {str(exc).split(' (at')[0]}",
                     line=int(match.group(1)) if match else None)
        return None
    tyre = (_table(problems, file, "tyre", data["tyre"], _TYRE, warnings) if "tyre" in data
            else None)
    if "tyre" not in data:
        problems.add(file, "missing required table [tyre]", key="tyre")
    elif tyre is not None and tyre.get("source", "measured") not in _SOURCES:
        problems.add(file, f"unknown source '{tyre['source']}' (expected one of: "
                           f"{', '.join(_SOURCES)})", key="tyre.source")
    rig = _table(problems, file, "rig", data["rig"], _RIG) if "rig" in data else None
    runs_data = data.get("runs", [])
    if not isinstance(runs_data, list) or not runs_data:
        problems.add(file, "expected at least one [[runs]] entry", key="runs")
        runs_data = runs_data if isinstance(runs_data, list) else []
    runs = [_run(problems, file, i, entry, warnings) for i, entry in enumerate(runs_data)]
    seen: dict[str, int] = {}
    for i, run in enumerate(runs):
        if run is None:
            continue
        if run.id in seen:
            problems.add(file, f"duplicate run id '{run.id}' (also runs[{seen[run.id]}])",
                         key=f"runs[{i}].id")
        seen.setdefault(run.id, i)
    flat = [i for i, e in enumerate(runs_data) if isinstance(e, dict) and e.get("kind") ==
            "flatplank"]
    if flat and "rig" not in data:
        problems.add(file, "missing table [rig] (hub_a_m, hub_b_m): needed for the flatplank "
                           f"run runs[{flat[0]}]", key="rig")
    if problems.total > start:
        if not partial:
            return None
        nan = float("nan")  # partial: keep what is valid, so that a check can go on
        tyre = {"id": "", "nominal_pressure_Pa": nan, "nominal_load_N": nan,
                "unloaded_radius_m": nan, **(tyre or {})}
        rig = rig if rig is not None and {"hub_a_m", "hub_b_m"} <= rig.keys() else None
    extra = {k: v for k, v in data.items() if k not in ("tyre", "rig", "runs")}
    return Manifest(file, TyreInfo(**tyre), None if rig is None else RigInfo(**rig),
                    tuple(r for r in runs if r is not None), extra)


def _run(problems: Problems, file: str, i: int, entry: Any,
         warnings: list | None = None) -> RunSpec | None:
    where = f"runs[{i}]"
    start = problems.total
    run = _table(problems, file, where, entry, _RUN)
    if run is None:
        return None
    kind = run.get("kind")
    if kind is not None and kind not in KINDS:
        problems.add(file, f"unknown kind '{kind}' (expected one of: {', '.join(KINDS)})",
                     key=f"{where}.kind")
        kind = None
    test = run.get("test")
    if kind in ("trailer", "flatplank") and test is None and "test" not in entry:
        problems.add(file, f"missing required key (string; one of: {', '.join(TESTS[kind])})",
                     key=f"{where}.test")
    elif kind is not None and test is not None and test not in TESTS[kind]:
        problems.add(file, f"unknown {kind} test '{test}' (expected one of: "
                           f"{', '.join(TESTS[kind])})", key=f"{where}.test")
    axes = axes_name(run.get("axes", "ISO-W")) or run.get("axes")
    if axes not in AXES:
        problems.add(file, f"unknown axis system '{axes}' (expected one of: {', '.join(AXES)})",
                     key=f"{where}.axes")
    units = run.get("units", {})
    for channel, unit in units.items():
        why = (f"expected a unit string, got {_typename(unit)}" if not isinstance(unit, str)
               else unit_problem(unit))
        if why:
            problems.add(file, why, key=f"{where}.units.{channel}")
    conditions = _table(problems, file, f"{where}.conditions", run.get("conditions", {}),
                        _CONDITIONS, warnings)
    if problems.total > start or "file" not in run:
        return None
    return RunSpec(id=run.get("id", Path(run["file"]).stem), file=run["file"], kind=kind,
                   test=test or "any", axes=axes, units=units, conditions=conditions or {})
