"""``mfid extract``: raw Flatplank runs of a measurement folder -> characteristics.csv."""
from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import typer

from identify.cli.app import app, err_console, fail, out_console
from identify.core.atomic import atomic_write_csv, atomic_write_text
from identify.core.errors import InputError, MfidError
from identify.extract import extract_folder
from identify.io.folder import load_folder
from identify.io.output_guard import check_file_output, measurement_inputs


@app.command("extract")
def extract_command(
    folder: Path = typer.Argument(..., help="Measurement folder (with tyre.toml)."),
    output: Path = typer.Option(..., "--output", "-o",
                                help="Characteristic table to write (CSV: quantity, pi_bar, "
                                     "Fz_N, value, unit, Vx_mps, gamma_deg, mode)."),
    diagnostics: Path | None = typer.Option(
        None, "--diagnostics", "-d",
        help="Also write the per-run diagnostics and flags (extraction.json)."),
) -> None:
    """Extract CFz, CFx, CFy, CMz, sigma_y, Re and the camber characteristics from the raw
    Flatplank runs (eigenfrequencies are passed through) and report the data problems found.

    The measurement folder is only read; outputs must lie outside it.
    """

    try:
        inputs = measurement_inputs(folder)
        for target, key in ((output, "--output"), (diagnostics, "--diagnostics")):
            if target is not None:
                check_file_output(target, inputs, key=key)
        with err_console.status(f"extracting {folder} ..."):
            result = extract_folder(load_folder(folder))
        if result.characteristics.empty:
            raise InputError(folder, "no Flatplank runs or characteristics to extract")
        atomic_write_csv(result.characteristics, output)
        if diagnostics is not None:
            atomic_write_text(diagnostics, json.dumps(result.to_dict(), indent=1,
                                                      allow_nan=False) + "\n")
    except MfidError as exc:
        fail(exc)
    out_console.print(f"wrote {output}: {result.summary()} ({result.seconds:.1f} s)",
                      markup=False)
    counts = Counter((f["flag"], f["test"]) for f in result.flags)
    for (flag, test), n in sorted(counts.items()):
        out_console.print(f"  flag {flag}: {n} in {test}", markup=False)
    if diagnostics is not None:
        out_console.print(f"wrote {diagnostics}", markup=False)
