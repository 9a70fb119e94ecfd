"""``mfid check``: validate a measurement folder and list every problem found."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from identify.cli.app import app, err_console, out_console


@app.command("check")
def check_command(
    folder: Path = typer.Argument(..., help="Measurement folder (with tyre.toml), its tyre.toml, "
                                            "or a single characteristics CSV."),
    nominal_pressure: Optional[float] = typer.Option(
        None, "--nominal-pressure", help="Nominal pressure [Pa] of a single characteristics CSV."),
    nominal_load: Optional[float] = typer.Option(
        None, "--nominal-load", help="Nominal load [N] of a single characteristics CSV."),
) -> None:
    """Check a measurement folder: print each problem on its own line (stderr), exit 2 if any.

    The folder is only read, never modified.
    """
    from identify.io.folder import scan_folder

    found, problems = scan_folder(folder, nominal_pressure_Pa=nominal_pressure,
                                  nominal_load_N=nominal_load)
    if problems:
        for problem in problems:
            err_console.print(str(problem), markup=False)
        err_console.print(f"{len(problems)} problem(s) in {folder}", markup=False)
        raise typer.Exit(2)
    out_console.print(f"{folder}: ok; {found.summary()}", markup=False)
