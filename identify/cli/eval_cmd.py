"""``mfid eval``: evaluate a .tir file on a table of operating points."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from identify.cli.app import app, err_console, fail, out_console
from identify.core.atomic import atomic_write_csv
from identify.core.errors import InputError, MfidError
from identify.io.output_guard import Inputs, check_file_output
from identify.io.tables.points import read_points
from identify.io.tir import read_tir
from identify.io.tir.limits import inverted_limits, missing_sections, points_outside
from identify.model.evaluate import OUTPUT_COLUMNS, SolverOptions, evaluate_frame
from identify.model.kernel.fused import evaluate_fused_frame
from identify.model.modes import UseMode


class Engine(str, Enum):
    """Which implementation of the forward model evaluates the points."""

    numpy = "numpy"
    fused = "fused"


def _warnings(path: Path, tirfile, points, clipped: bool) -> list[str]:
    """What the .tir does not cover: coefficient sections missing altogether (evaluated on
    their defaults) and points beyond the file's own limits (counted per key)."""
    lines = []
    for section, keys in missing_sections(tirfile).items():
        shown = ", ".join(keys[:6]) + (f", ... ({len(keys)} keys)" if len(keys) > 6 else "")
        lines.append(f"{path}: [{section}] is missing: its keys ({shown}) take their defaults, "
                     "so these outputs are not the file's tyre")
    outside = points_outside(tirfile, points)
    if outside:
        n = len(points)
        parts = ", ".join(f"{o.count} beyond {o.key} = {o.value:g}" for o in outside)
        lines.append(f"{path}: points outside the file's limits ({parts}) of {n} points: "
                     + ("clipped to them (limit checks of this useMode)" if clipped else
                        "extrapolated (no limit checks in this useMode)")
                     + ", where the file claims nothing")
    return lines


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
        inverted = inverted_limits(tirfile)
        if inverted:
            raise InputError(tir, f"{'; '.join(inverted)}: no operating point lies in the range "
                                  "the file declares valid", key=inverted[0].split()[0])
        points = read_points(input)
        if engine is Engine.fused:
            result = evaluate_fused_frame(tirfile.params(), points, mode=use_mode)
        else:
            solver = SolverOptions.mfeval_call() if mfeval_call else SolverOptions()
            result = evaluate_frame(tirfile.params(), points, mode=use_mode, solver=solver)
        atomic_write_csv(result, output)
    except MfidError as exc:
        fail(exc)
    for line in _warnings(tir, tirfile, points, use_mode.limits):
        err_console.print(f"warning: {line}", markup=False, highlight=False)
    out_console.print(f"wrote {output} ({len(result)} points x {len(OUTPUT_COLUMNS)} outputs, "
                      f"FITTYP {tirfile.fittyp}, mode {mode}, {engine.value})")
