"""``mfid report``: rebuild the PDF report from a saved fit directory, without refitting."""
from __future__ import annotations

from pathlib import Path

import typer

from identify.cli.app import app, fail, out_console
from identify.core.errors import MfidError
from identify.io.fitdir import read_fit_dir
from identify.io.output_guard import Inputs, check_file_output
from identify.report.pdf import default_report_path, write_report


@app.command("report")
def report_command(
    fit_dir: Path = typer.Argument(..., metavar="FITDIR",
                                   help="A fit directory written by mfid fit (fits/<tyre id>/)."),
    output: Path | None = typer.Option(None, "--output", "-o",
                                          help="PDF to write (default reports/<tyre id>.pdf)."),
) -> None:
    """Rebuild the PDF fit report from FITDIR alone (fit.json, measured_vs_model.csv, the
    .tir, extraction.json and saved MCMC chains)."""

    try:
        fd = read_fit_dir(fit_dir)
        target = check_file_output(output if output is not None else default_report_path(fd),
                                   Inputs.of(folders=(fit_dir,)), key="--output")
        report = write_report(fd, target)
    except KeyboardInterrupt:
        out_console.print("interrupted: no partial report was left", markup=False)
        raise typer.Exit(130) from None
    except MfidError as exc:
        fail(exc)
    out_console.print(f"wrote {report.path} ({report.n_pages} pages)", markup=False,
                      highlight=False)
