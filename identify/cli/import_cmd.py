"""``mfid import``: trailer files (a TTC session, plain CSV/HDF5/TYDEX) -> a measurement folder."""
from __future__ import annotations

import shlex
from pathlib import Path

import typer

from identify.cli.app import app, err_console, fail, out_console
from identify.cli.fit_cmd import StageProgress
from identify.core.errors import InputError, MfidError
from identify.io.axes import AXES, axes_name
from identify.io.output_guard import Inputs, check_folder_output
from identify.workflows.import_session import import_session


def parse_units(items: list[str]) -> dict[str, str]:
    """``["SA=deg,P=kPa", "FZ=lbf"]`` -> {channel: unit}.

    Raises
    ------
    InputError
        For an item that is not CHANNEL=UNIT.
    """
    out: dict[str, str] = {}
    for item in items:
        for part in (p.strip() for p in item.split(",") if p.strip()):
            name, sep, unit = part.partition("=")
            if not sep or not name.strip() or not unit.strip():
                raise InputError(None, f"expected CHANNEL=UNIT, not {part!r}", key="--units")
            out[name.strip()] = unit.strip()
    return out


def _command(files, out, tyre_id, pressure, load, radius, units, axes) -> str:
    args = ["mfid", "import", *map(str, files), "--out", str(out)]
    for flag, value in (("--id", tyre_id), ("--nominal-pressure", pressure),
                        ("--nominal-load", load), ("--unloaded-radius", radius),
                        ("--axes", axes)):
        if value is not None:
            args += [flag, f"{value:g}" if isinstance(value, float) else str(value)]
    for item in units:
        args += ["--units", item]
    return shlex.join(args)


@app.command("import")
def import_command(
    files: list[Path] = typer.Argument(..., help="Trailer files: TTC .mat/.dat (a run's .mat "
                                                 "and .dat are imported once), CSV, HDF5 or "
                                                 "TYDEX."),
    out: Path = typer.Option(..., "--out", help="The measurement folder to write (absent or "
                                                "empty)."),
    tyre_id: str | None = typer.Option(None, "--id", help="Tyre id (default: the files' "
                                                             "tireid), made a safe file name."),
    nominal_pressure: float | None = typer.Option(
        None, "--nominal-pressure", metavar="PA",
        help="Nominal pressure [Pa] (default: the middle pressure level of the data)."),
    nominal_load: float | None = typer.Option(
        None, "--nominal-load", metavar="N",
        help="Nominal load [N] (default: the middle load level of the data)."),
    unloaded_radius: float | None = typer.Option(
        None, "--unloaded-radius", metavar="M",
        help="Unloaded radius [m] (default: the loaded radius RL extrapolated to zero load)."),
    units: list[str] = typer.Option([], "--units", metavar="CHANNEL=UNIT",
                                    help="Units of channels the files do not give (plain CSV, "
                                         "a TTC .mat without its channel struct: it replaces "
                                         "the assumed TTC convention); repeat or separate "
                                         "with commas."),
    axes: str | None = typer.Option(None, "--axes",
                                       help="Axis system of plain files: ISO-W (default), SAE "
                                            "or TYDEX-C (TTC files are SAE)."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace a non-empty --out."),
) -> None:
    """Import trailer files into a new measurement folder (channel files + tyre.toml).

    The tyre id, each run's test (from its sweeps), the nominal pressure and load (the middle
    levels) and the unloaded radius come from the data; units and axes are recorded. The input
    files are copied, never modified. Quirks of the data (repeated time stamps, dropouts,
    spikes, NaN stretches, implausible channels) are listed as warnings; `mfid check` lists
    them again. Exit 2 on a file that cannot be used (one line naming file and channel).
    """

    try:
        axes = axes_name(axes) or axes if axes is not None else None
        if axes is not None and axes not in AXES:
            raise InputError(None, f"unknown axis system '{axes}' (expected one of: "
                                   f"{', '.join(AXES)})", key="--axes")
        # --overwrite clears --out: it must hold no input file (nor be one)
        check_folder_output(out, Inputs.of(files=files), key="--out")
        with StageProgress() as progress:
            result = import_session(
                files, out, tyre_id=tyre_id, nominal_pressure_Pa=nominal_pressure,
                nominal_load_N=nominal_load, unloaded_radius_m=unloaded_radius,
                units=parse_units(units) or None, axes=axes, overwrite=overwrite,
                command=_command(files, out, tyre_id, nominal_pressure, nominal_load,
                                 unloaded_radius, units, axes), progress=progress)
    except MfidError as exc:
        fail(exc)
    for warning in result.warnings:
        err_console.print(f"warning: {warning}", markup=False)
    out_console.print(f"wrote {result.path}: tyre {result.tyre_id}", markup=False)
    for run in result.runs:
        out_console.print(f"  {run.id}: {run.test}, {run.samples} samples, {run.sweeps} sweeps "
                          f"({run.file}, axes {run.axes})", markup=False)
    for note in result.notes:
        out_console.print(f"  {note}", markup=False)
    levels = result.segmentation.levels
    for channel, unit, scale in (("p", "kPa", 1e-3), ("Fz", "N", 1.0)):
        values = ", ".join(f"{lv.value * scale:.4g}" for lv in levels.get(channel, ()))
        out_console.print(f"  {channel} levels [{unit}]: {values}", markup=False)
    out_console.print(f"{len(result.warnings)} warning(s); next: mfid check {result.path}",
                      markup=False)
