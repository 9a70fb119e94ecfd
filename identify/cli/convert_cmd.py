"""``mfid convert``: convert a trailer channel file between CSV, HDF5 and TYDEX."""
from __future__ import annotations

from pathlib import Path

import typer

from identify.cli.app import app, fail, out_console
from identify.core.errors import InputError, MfidError
from identify.io.common import Problems
from identify.io.manifest import MANIFEST_NAME, read_manifest
from identify.io.output_guard import Inputs, check_file_output
from identify.io.trailer.files import read_channels, write_channels

_FORMATS = (".csv", ".h5", ".hdf5", ".tdx")


def _manifest_run(src: Path):
    """The manifest run that names ``src`` (tyre.toml in its folder or the one above) and
    that measurement folder, or (None, None)."""

    for folder in (src.parent, src.parent.parent):
        toml = folder / MANIFEST_NAME
        if not toml.is_file():
            continue
        manifest = read_manifest(toml, Problems(), partial=True)
        for run in manifest.runs if manifest else ():
            if (folder / run.file).resolve() == src.resolve():
                return run, folder
    return None, None


def _parse_units(pairs: list[str]) -> dict[str, str]:
    units = {}
    for pair in pairs:
        name, sep, unit = pair.partition("=")
        if not sep or not name.strip() or not unit.strip():
            raise InputError(None, f"expected CHANNEL=UNIT, got '{pair}'", key="--unit")
        units[name.strip()] = unit.strip()
    return units


@app.command("convert")
def convert_command(
    src: Path = typer.Argument(..., help="Trailer channel file: CSV, HDF5 or TYDEX (detected "
                                         "from the content)."),
    dst: Path = typer.Argument(..., help="Output file; the format follows the extension: "
                                         ".csv, .h5/.hdf5 or .tdx."),
    run: str | None = typer.Option(None, "--run", help="Run id: the HDF5 group to read, "
                                                          "and the name of the run written."),
    unit: list[str] = typer.Option([], "--unit", help="CHANNEL=UNIT for a channel the file "
                                                      "gives in non-SI units (repeatable)."),
) -> None:
    """Convert trailer channels to SI values in another format (names and axes kept).

    Units: --unit, else the manifest run that lists SRC, else the file. Atomic write.
    """

    try:
        spec, folder = _manifest_run(src) if src.is_file() else (None, None)
        # a file of a measurement folder: the folder is never written into
        check_file_output(dst, Inputs.of(files=(src,), folders=(folder,)))
        if dst.suffix.lower() not in _FORMATS:
            raise InputError(dst, "unknown output format: expected .csv, .h5, .hdf5 or .tdx")
        units = _parse_units(unit)
        if spec is not None:
            units = {**spec.units, **units}
            run = run or (spec.id if src.suffix.lower() not in (".h5", ".hdf5") else None)
        runs = read_channels(src, run=run, units=units)
        write_channels(runs, dst)
    except MfidError as exc:
        fail(exc)
    samples = sum(len(next(iter(r.data.values()), ())) for r in runs)
    out_console.print(f"wrote {dst} ({len(runs)} run(s), {samples} samples)", markup=False)
