"""``mfid check``: validate a measurement folder; list every error, then every warning."""
from __future__ import annotations

from pathlib import Path

import typer

from identify.cli.app import app, err_console, out_console
from identify.io.folder import inspect_folder


@app.command("check")
def check_command(
    folder: Path = typer.Argument(..., help="Measurement folder (with tyre.toml), its tyre.toml, "
                                            "or a single characteristics CSV."),
    nominal_pressure: float | None = typer.Option(
        None, "--nominal-pressure", help="Nominal pressure [Pa] of a single characteristics CSV."),
    nominal_load: float | None = typer.Option(
        None, "--nominal-load", help="Nominal load [N] of a single characteristics CSV."),
) -> None:
    """Check a measurement folder: errors and warnings, each on its own line (stderr).

    Errors (the data cannot be used) are listed first, then warnings (``warning: ...``: quirks
    of usable trailer data, cleaned while loading, each with its count); exit 2 if there is
    any error, else 0. The folder is only read, never modified.
    """

    scan = inspect_folder(folder, nominal_pressure_Pa=nominal_pressure,
                          nominal_load_N=nominal_load)
    for problem in scan.problems:
        err_console.print(str(problem), markup=False)
    for warning in scan.warnings:
        err_console.print(f"warning: {warning}", markup=False)
    counted = f", {len(scan.warnings)} warning(s)" if scan.warnings else ""
    if scan.problems:
        err_console.print(f"{len(scan.problems)} problem(s){counted} in {folder}", markup=False)
        raise typer.Exit(2)
    note = (f" with {len(scan.warnings)} warning(s) (usable data, cleaned while loading)"
            if scan.warnings else "")
    out_console.print(f"{folder}: ok{note}; {scan.found.summary()}", markup=False)
