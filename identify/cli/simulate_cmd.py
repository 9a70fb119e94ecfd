"""``mfid simulate``: write a simulated measurement folder (Flatplank, trailer, truth), or with
``--format ttc`` a simulated Tire Test Consortium session (.mat and .dat files, truth)."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from identify.cli.app import app, fail, out_console
from identify.core.errors import InputError, MfidError
from identify.io.output_guard import Inputs, check_folder_output
from identify.io.tir import read_tir
from identify.simulate import default_tir_path, simulate_folder
from identify.simulate.ttc import simulate_ttc


class GridChoice(str, Enum):
    full = "full"
    small = "small"


class FormatChoice(str, Enum):
    folder = "folder"
    ttc = "ttc"


class UnitsChoice(str, Enum):
    SI = "SI"
    USCS = "USCS"


class MatVersionChoice(str, Enum):
    v5 = "5"
    v73 = "7.3"


def parse_names(items: list[str]) -> list[str]:
    """``["N,RE", "SR"]`` -> ``["N", "RE", "SR"]`` (repeat or separate with commas)."""
    return [p.strip() for item in items for p in item.split(",") if p.strip()]


def parse_hide(items: list[str]) -> dict[str, float]:
    """``["PPY5=-0.15", "QSY8=-0.4,CFy.p2=-0.05"]`` -> {name: value}.

    Raises
    ------
    InputError
        For an item that is not NAME=VALUE with a finite number.
    """
    out: dict[str, float] = {}
    for item in items:
        for part in (p.strip() for p in item.split(",")):
            name, sep, value = part.partition("=")
            name = name.strip()
            try:
                number = float(value)
            except ValueError:
                number = None
            if not sep or not name or number is None or number != number:
                raise InputError(None, f"expected NAME=VALUE with a number, not {part!r}",
                                 key="--hide")
            out[name] = number
    return out


@app.command("simulate")
def simulate_command(
    tir: str = typer.Argument(..., help="Tyre property file (.tir), or 'default' for the "
                                        "bundled 225/50 R17 tyre."),
    outdir: Path = typer.Argument(..., help="Folder to create (absent or empty)."),
    seed: int = typer.Option(0, "--seed", help="Noise seed; equal seeds give equal folders."),
    noise: float = typer.Option(0.01, "--noise", help="Noise std as a fraction of each "
                                                      "channel's RMS."),
    ar1: float | None = typer.Option(None, "--ar1", help="Lag-one correlation of the noise "
                                                            "(AR(1)); default 0 (folder), "
                                                            "0.7 (ttc)."),
    fmt: FormatChoice = typer.Option(FormatChoice.folder, "--format",
                                     help="folder: a measurement folder; ttc: a Tire Test "
                                          "Consortium session (.mat + .dat per run, "
                                          "truth.json) to try `mfid import` on."),
    units: UnitsChoice = typer.Option(UnitsChoice.SI, "--units",
                                      help="--format ttc: the files' unit system."),
    implausible: list[str] = typer.Option([], "--implausible", metavar="CHANNEL",
                                          help="--format ttc: make channels implausible: N "
                                               "(near zero at 40 kph), RE (hundreds of "
                                               "metres), SR (pinned at -1); repeat or "
                                               "separate with commas."),
    cornering_only: bool = typer.Option(False, "--cornering-only",
                                        help="--format ttc: the cornering run only."),
    mat_version: MatVersionChoice = typer.Option(MatVersionChoice.v5, "--mat-version",
                                    help="--format ttc: MATLAB format of the .mat files, 5 "
                                         "or 7.3 (HDF5 inside)."),
    relaxation: float = typer.Option(0.0, "--relaxation", metavar="METRES",
                                     help="--format ttc: lateral relaxation length: the forces "
                                          "lag the slip angle set over this rolling distance "
                                          "(a real machine's up/down-sweep loop); 0: none."),
    input_noise: float | None = typer.Option(None, "--input-noise",
                                                help="--format ttc: noise of the slip, camber, "
                                                     "load and speed channels (SA, SL, SR, IA, "
                                                     "FZ, V, N) as a fraction of each one's "
                                                     "RMS; default: --noise."),
    transients: bool = typer.Option(True, "--transients/--no-transients",
                                    help="Start-up transients in stiffness runs."),
    stick_slip: bool = typer.Option(True, "--stick-slip/--no-stick-slip",
                                    help="Stick-slip after saturation."),
    asymmetry: float = typer.Option(0.0, "--asymmetry", help="Camber forces at negative "
                                                             "camber scaled by (1 + value)."),
    short_relaxation: bool = typer.Option(True, "--short-relaxation/--no-short-relaxation",
                                          help="Relaxation runs of the longest-sigma cell too "
                                               "short for steady state."),
    hide: list[str] = typer.Option([], "--hide", metavar="NAME=VALUE",
                                   help="Give the data an effect the recorded base model "
                                        "lacks (.tir key or CFy.p2-style relation "
                                        "coefficient); repeat or separate with commas."),
    grid: GridChoice = typer.Option(GridChoice.full, "--grid", help="Test grid."),
    digits: int = typer.Option(0, "--digits", help="Significant digits of the channel files "
                                                   "(0 = exact round trip)."),
    gzip_files: bool = typer.Option(False, "--gzip", help="Write the channel files "
                                                          "gzip-compressed (.csv.gz)."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace a non-empty OUTDIR."),
) -> None:
    """Simulate every Flatplank and trailer test of a tyre into a measurement folder; or,
    with --format ttc, a TTC trailer session (a cornering and a drive/brake run in the TTC
    .mat and .dat formats, with warm-ups, drift and logging quirks; truth.json)."""

    try:
        hidden = parse_hide(hide)
        path = default_tir_path() if tir == "default" else Path(tir)
        if not path.is_file():
            raise InputError(path, "no such .tir file")
        check_folder_output(outdir, Inputs.of(files=(path,)), key="OUTDIR")
        if fmt is FormatChoice.ttc:
            tireid = "mfid-sim 225/50 R17" if tir == "default" else f"mfid-sim {path.stem}"
            session = simulate_ttc(read_tir(path).params(), outdir, seed=seed, noise=noise,
                                   ar1=0.7 if ar1 is None else ar1, units=units.value,
                                   implausible=parse_names(implausible),
                                   cornering_only=cornering_only, tireid=tireid,
                                   mat_version=mat_version.value, relaxation=relaxation,
                                   input_noise=input_noise, overwrite=overwrite)
            runs = ", ".join(f"{r['stem']} ({r['test']}, {r['samples']} samples)"
                             for r in session.truth["runs"])
            out_console.print(f"wrote {session.path}: {runs}; .mat and .dat each, "
                              f"truth.json (seed {seed})")
            return
        result = simulate_folder(read_tir(path).params(), outdir, seed=seed, noise=noise,
                                 ar1_rho=ar1 or 0.0, transients=transients,
                                 stick_slip=stick_slip,
                                 asymmetry=asymmetry, short_relaxation=short_relaxation,
                                 hide=hidden, grid=grid.value, overwrite=overwrite,
                                 digits=digits or None, compress=gzip_files)
    except MfidError as exc:
        fail(exc)
    out_console.print(f"wrote {result.path} ({len(result.run_ids)} runs, "
                      f"{len(result.truth['characteristics'])} true characteristics, "
                      f"seed {seed})")
