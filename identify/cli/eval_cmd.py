"""``mfid eval``: evaluate a .tir file on a table of operating points."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from identify.cli.app import app, fail, out_console
from identify.core.errors import InputError, MfidError
from identify.io.outputs import Inputs, check_file_output
from identify.io.points import read_points
from identify.io.tir import read_tir
from identify.model.evaluate import OUTPUT_COLUMNS, SolverOptions, evaluate_frame
from identify.model.modes import UseMode
from identify.io.atomic import atomic_write_csv
from identify.model.kernel import evaluate_fused_frame


class Engine(str, Enum):
    """Which implementation of the forward model evaluates the points."""

    numpy = "numpy"
    fused = "fused"


@app.command("eval")
def eval_command(
    tir: Path = typer.Argument(..., help="Tyre property file (.tir), MF 6.1 or 6.2."),
    input: Path = typer.Option(..., "--input", "-i",
                               help="CSV of operating points: Fz, kappa, alpha, gamma, Vx, p "
                                    "(SI, rad); optional phit, omega."),
    output: Path = typer.Option(..., "--output", "-o", help="CSV to write (inputs + outputs)."),
    mode: int = typer.Option(111, "--mode", help="MFeval useMode: 111, 121, 211 or 221."),
    engine: Engine = typer.Option(Engine.numpy, "--engine",
                                  help="numpy (reference) or fused (compiled kernel, faster "
                                       "on large inputs)."),
    mfeval_call: bool = typer.Option(False, "--mfeval-call",
                                     help="Reproduce ONE MFeval call over all points: Re "
                                          "iteration stops when any point converged, MF 6.2 "
                                          "secant stops at MFeval's tolerance."),
) -> None:
    """Evaluate the Magic Formula on operating points and write every model output.

    Output: the input columns, then Fx, Fy, Fz, Mx, My, Mz, Re, rho, 2a, t, mux, muy, omega,
    Rl, 2b, Mzr, Cx, Cy, Cz, Kya, sigmax, sigmay, Kxk (ISO-W, SI). Fz and omega hold the
    model's values (load after the negative clip; spin rate used).
    """

    try:
        try:
            use_mode = UseMode.from_code(mode)
        except ValueError as exc:
            raise InputError(None, str(exc), key="--mode") from None
        if engine is Engine.fused and mfeval_call:
            raise InputError(None, "--mfeval-call needs --engine numpy", key="--engine")
        check_file_output(output, Inputs.of(files=(tir, input)), key="--output")
        tirfile = read_tir(tir)
        points = read_points(input)
        if engine is Engine.fused:
            result = evaluate_fused_frame(tirfile.params(), points, mode=use_mode)
        else:
            solver = SolverOptions.mfeval_call() if mfeval_call else SolverOptions()
            result = evaluate_frame(tirfile.params(), points, mode=use_mode, solver=solver)
        atomic_write_csv(result, output)
    except MfidError as exc:
        fail(exc)
    out_console.print(f"wrote {output} ({len(result)} points x {len(OUTPUT_COLUMNS)} outputs, "
                      f"FITTYP {tirfile.fittyp}, mode {mode}, {engine.value})")
