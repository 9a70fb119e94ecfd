"""``mfid eval``: evaluate a .tir file on a table of operating points."""
from __future__ import annotations

from pathlib import Path

import typer

from identify.cli.app import app, fail, out_console
from identify.errors import MfidError


@app.command("eval")
def eval_command(
    tir: Path = typer.Argument(..., help="Tyre property file (.tir), MF 6.1 or 6.2."),
    input: Path = typer.Option(..., "--input", "-i",
                               help="CSV of operating points: Fz, kappa, alpha, gamma, Vx, p "
                                    "(SI, rad); optional phit, omega."),
    output: Path = typer.Option(..., "--output", "-o", help="CSV to write (inputs + outputs)."),
    mode: int = typer.Option(111, "--mode", help="MFeval useMode: 111, 121, 211 or 221."),
) -> None:
    """Evaluate the Magic Formula on operating points and write every model output."""
    from identify.load.points import read_points
    from identify.load.tir import read_tir
    from identify.model.evaluate import OUTPUT_COLUMNS, evaluate_frame
    from identify.report.atomic import atomic_write_csv

    try:
        tirfile = read_tir(tir)
        points = read_points(input)
        result = evaluate_frame(tirfile.params(), points, mode=mode)
        atomic_write_csv(result, output)
    except MfidError as exc:
        fail(exc)
    out_console.print(f"wrote {output} ({len(result)} points, {len(OUTPUT_COLUMNS)} outputs, "
                      f"mode {mode})")
