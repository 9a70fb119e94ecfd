"""``mfid vehicle``: a .tir and a vehicle -> vehicle.json, CSV tables and a PDF.

Everything is computed before anything is written, so bad input (a .tir that cannot be read,
a vehicle file with an unknown key, a pressure no tyre runs at) leaves no file behind; each
output is written to a temporary name and renamed. ``mfid fit --vehicle`` calls
:func:`add_vehicle_to_fit`, which writes the same JSON and CSVs into the fit directory's
``vehicle/`` folder, where the fit report finds them.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import pandas as pd
from matplotlib.backends.backend_pdf import PdfPages

from identify.core.atomic import atomic_path, atomic_write_csv, atomic_write_text
from identify.core.errors import InputError
from identify.core.jsonsafe import json_text
from identify.core.version import __version__
from identify.io.tir import read_tir
from identify.report.pdf import add_outline
from identify.report.vehicle_pages import VEHICLE_DIR, vehicle_pages
from identify.vehicle.analysis import (
    BAR,
    DEFAULT_SETTINGS_BAR,
    EXTRA_KEYS,
    FIGURE_KEYS,
    VehicleOptions,
    VehicleResult,
    analyse,
    parse_pressures,
)
from identify.vehicle.spec import VehicleSpec, default_vehicle, read_vehicle
from identify.vehicle.tyre import MfTyre

__all__ = ["analyse_vehicle", "write_vehicle_outputs", "add_vehicle_to_fit", "VehicleOutputs",
           "OUTPUT_NAMES"]

OUTPUT_NAMES = {"json": "vehicle.json", "settings": "settings.csv",
                "handling": "handling_diagram.csv", "response": "frequency_response.csv",
                "stiffness": "axle_stiffness_vs_pressure.csv", "pdf": "vehicle.pdf"}
"""The files written into the output folder."""


@dataclass(frozen=True)
class VehicleOutputs:
    """What :func:`write_vehicle_outputs` wrote: the result and each file."""

    result: VehicleResult
    files: tuple[Path, ...]


def _pressures(pressures: Iterable[str | tuple[float, float]] | None
               ) -> list[tuple[float, float]]:
    if pressures is None:
        return [(f * BAR, r * BAR) for f, r in DEFAULT_SETTINGS_BAR]
    out = []
    for p in pressures:
        if isinstance(p, str):
            out.append(parse_pressures(p))
        else:
            front, rear = (float(x) for x in p)
            if not all(math.isfinite(x) and 0.5 * BAR <= x <= 10 * BAR for x in (front, rear)):
                raise InputError(None, f"({front:g}, {rear:g}) Pa is not a pair of tyre "
                                       "pressures in Pa (0.5-10 bar)", key="pressures")
            out.append((front, rear))
    if not out:
        raise InputError(None, "no pressure setting given", key="--pressures")
    return out


def _spec(vehicle: str | Path | VehicleSpec | None) -> VehicleSpec:
    if vehicle is None:
        return default_vehicle()
    if isinstance(vehicle, VehicleSpec):
        return vehicle
    return read_vehicle(vehicle)


UNIDENTIFIED_MARK = "default, not identified"
"""The comment mfid's .tir writer puts on a key the data did not determine."""
_KEY_GROUPS = (
    (("PKY1", "PKY2", "PDY1"), "lateral-force keys (PKY1, PKY2, PDY1)",
     "the handling figures describe the default tyre's, not this tyre's"),
    (("PPY1", "PPY2"), "cornering-stiffness pressure keys (PPY1, PPY2)",
     "the handling figures' change with pressure is the defaults'"),
    (("LATERAL_STIFFNESS", "PCFY3"), "lateral-stiffness keys (LATERAL_STIFFNESS, PCFY3)",
     "the relaxation lengths, and with them the frequency responses' tyre lag, are the "
     "defaults'"),
    (("PFZ1",), "vertical-stiffness pressure key (PFZ1)",
     "the ride's change with pressure is the default's"),
)


def unidentified_keys(path: str | Path, defaults_used: Iterable[str]) -> set[str]:
    """Keys of a .tir that hold no identified value: those the reader filled with defaults and
    those mfid's writer marked "default, not identified by these data"."""
    keys = set(defaults_used)
    try:
        lines = Path(path).read_text("utf-8", errors="replace").splitlines()
    except OSError:
        return keys
    for line in lines:
        name, sep, rest = line.partition("=")
        if sep and UNIDENTIFIED_MARK in rest:
            keys.add(name.strip().upper())
    return keys


def tyre_notes(unidentified: set[str]) -> list[str]:
    """What the vehicle figures cannot say because the .tir's keys are defaults."""
    notes = []
    for keys, what, consequence in _KEY_GROUPS:
        if any(k in unidentified for k in keys):
            notes.append(f"the .tir's {what}: default values, not identified; {consequence}")
    return notes


def analyse_vehicle(tir: str | Path, vehicle: str | Path | VehicleSpec | None = None,
                    pressures: Iterable[str | tuple[float, float]] | None = None, *,
                    out: str | Path | None = None, pdf: bool = True,
                    options: VehicleOptions | None = None, **option_fields: Any
                    ) -> VehicleResult:
    """Handling and ride of a vehicle on the tyre of ``tir`` at front/rear pressure settings.

    Parameters
    ----------
    tir : path
        MF 6.1/6.2 .tir with pressure coefficients (e.g. a fit's).
    vehicle : path, "default" or VehicleSpec, optional
        A vehicle file (docs/vehicle.md); absent or "default": the bundled default sedan.
    pressures : iterable, optional
        ``"FRONT/REAR"`` strings in bar (``"2.5/2.2"``) or (front, rear) pairs in Pa; absent:
        :data:`identify.vehicle.analysis.DEFAULT_SETTINGS_BAR`.
    out : path, optional
        Write vehicle.json, the CSVs and (``pdf``) vehicle.pdf into this folder.
    options : VehicleOptions, optional
        Or its fields as keywords (``road_class="C"``, ``seed=1`` ...).

    Returns
    -------
    VehicleResult
        ``.settings[i].figures`` holds the figures of setting i (vehicle.json's keys).
    """
    if options is None:
        names = {f.name for f in fields(VehicleOptions)}
        unknown = sorted(set(option_fields) - names)
        if unknown:
            raise TypeError(f"unknown option(s): {', '.join(unknown)}")
        options = VehicleOptions(**option_fields)
    elif option_fields:
        raise TypeError("give options or its fields as keywords, not both")
    options.check()
    spec = _spec(vehicle)
    settings = _pressures(pressures)
    tirfile = read_tir(tir)
    unidentified = unidentified_keys(tir, tirfile.defaults_used)
    tyre = MfTyre(tirfile.params(), damping_given="VERTICAL_DAMPING" not in unidentified,
                  vx=options.speed_kmh / 3.6)
    info = {"path": str(tir), "sha256": tirfile.sha256, "fittyp": tirfile.fittyp,
            "notes": tyre_notes(unidentified)}
    result = analyse(tyre, spec, settings, options, tyre_info=info, version=__version__)
    if out is not None:
        write_vehicle_outputs(result, out, pdf=pdf)
    return result


def tables(result: VehicleResult) -> dict[str, pd.DataFrame]:
    """The CSV tables of a result: settings, handling diagram, frequency response, axle
    stiffness against pressure."""
    rows = []
    for s in result.settings:
        row: dict[str, Any] = {"setting": s.label}
        row.update({k: s.figures.get(k, math.nan) for k in FIGURE_KEYS + EXTRA_KEYS})
        row.update({"limiting_axle": s.limiting_axle, "stable": s.stable,
                    "outside_validity": s.outside_validity})
        rows.append(row)
    handling = pd.concat([pd.DataFrame({"setting": s.label, **s.handling})
                          for s in result.settings], ignore_index=True)
    response = pd.concat([pd.DataFrame({"setting": s.label, **s.response})
                          for s in result.settings], ignore_index=True)
    return {"settings": pd.DataFrame(rows), "handling": handling, "response": response,
            "stiffness": pd.DataFrame(dict(result.stiffness_vs_pressure))}


def _write_pdf(result: VehicleResult, path: Path) -> None:
    meta = {"Title": f"mfid vehicle: {Path(str(result.tyre.get('path', ''))).name} on "
                     f"{result.spec.vehicle.name}",
            "Author": f"mfid {__version__}", "Creator": f"mfid {__version__} (matplotlib)",
            "Subject": "steady-state cornering, frequency response and ride at front/rear "
                       "pressure settings", "CreationDate": None}
    titles = []
    with atomic_path(path) as tmp:
        with PdfPages(tmp, metadata=meta) as pdf:
            for title, fig in vehicle_pages(result):
                pdf.savefig(fig)
                fig.clear()
                titles.append(title)
        add_outline(tmp, titles)


def write_vehicle_outputs(result: VehicleResult, out: str | Path, *, pdf: bool = True,
                          names: Sequence[str] = tuple(OUTPUT_NAMES)) -> VehicleOutputs:
    """Write ``result`` into the folder ``out`` (created): vehicle.json, settings.csv,
    handling_diagram.csv, frequency_response.csv, axle_stiffness_vs_pressure.csv and, with
    ``pdf``, vehicle.pdf."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create folder: {exc.strerror or exc}") from None
    written = []
    tabs = tables(result)
    for key in names:
        path = out / OUTPUT_NAMES[key]
        if key == "json":
            atomic_write_text(path, json_text(result.to_dict()) + "\n")
        elif key == "pdf":
            if not pdf:
                continue
            _write_pdf(result, path)
        else:
            atomic_write_csv(tabs[key], path)
        written.append(path)
    return VehicleOutputs(result, tuple(written))


def add_vehicle_to_fit(fit_dir: str | Path, tir: str | Path,
                       vehicle: str | Path | VehicleSpec | None = None,
                       options: VehicleOptions = VehicleOptions()) -> VehicleOutputs:
    """Run the vehicle analysis on a fit's .tir at the default settings and write its JSON
    and CSVs into ``fit_dir/vehicle/`` (the fit report adds the vehicle pages from there)."""
    result = analyse_vehicle(tir, vehicle, options=options)
    return write_vehicle_outputs(result, Path(fit_dir) / VEHICLE_DIR, pdf=False,
                                 names=[k for k in OUTPUT_NAMES if k != "pdf"])
