"""The ``tyre.toml`` manifest of a simulated folder (a small TOML writer for its few shapes)."""
from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence

from identify.core.tyre_size import size_designation
from identify.simulate.model import Run
from identify.simulate.rig import Rig

__all__ = ["toml_value", "manifest_text"]


def toml_value(value) -> str:
    """One TOML value: bool, int, finite float, string, or an inline table of those."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"cannot write a non-finite number to TOML: {value!r}")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string for the characters used here
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def manifest_text(tyre_id: str, params: Mapping[str, float], rig: Rig,
                  runs: Sequence[Run]) -> str:
    """The manifest: ``[tyre]``, ``[rig]``, one ``[[runs]]`` per run, then the eigenfrequency
    table (``characteristics.csv``)."""
    lines = ["# Simulated measurement folder written by `mfid simulate` (identify.simulate).",
             "# truth.json holds every parameter used and the true characteristics.",
             "[tyre]", f"id = {toml_value(tyre_id)}",
             f"nominal_pressure_Pa = {toml_value(int(round(params['NOMPRES'])))}",
             f"nominal_load_N = {toml_value(int(round(params['FNOMIN'])))}",
             f"unloaded_radius_m = {toml_value(float(params['UNLOADED_RADIUS']))}",
             'source = "simulated"']
    size = size_designation(float(params["WIDTH"]), float(params["ASPECT_RATIO"]),
                            float(params["RIM_RADIUS"]))
    if size is not None:  # the .tir's dimensions as the designation a tyre.toml carries
        lines.append(f"size = {toml_value(size)}")
    lines += ["", "[rig]",
             f"hub_a_m = {toml_value(float(rig.hub_a))}",
             f"hub_b_m = {toml_value(float(rig.hub_b))}"]
    entries = [(r.run_id, r.file, r.kind, r.test, r.conditions) for r in runs]
    entries.append(("characteristics", "characteristics.csv", "characteristics",
                    "eigenfrequency", {}))
    for run_id, file, kind, test, conditions in entries:
        lines += ["", "[[runs]]", f"id = {toml_value(run_id)}", f"file = {toml_value(file)}",
                  f"kind = {toml_value(kind)}", f"test = {toml_value(test)}", 'axes = "ISO-W"']
        if conditions:
            lines.append(f"conditions = {toml_value(conditions)}")
    return "\n".join(lines) + "\n"
