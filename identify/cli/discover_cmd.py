"""``mfid discover``: find the physical effect the base model is missing."""
from __future__ import annotations

import shlex
import sys
from contextlib import nullcontext
from pathlib import Path

import typer

from identify.cli.app import app, err_console, fail, out_console
from identify.cli.fit_cmd import StageProgress
from identify.core.errors import InputError, MfidError
from identify.discover.design import SCHEMES
from identify.discover.search import Settings
from identify.workflows.discover import discover_folder


@app.command("discover")
def discover_command(
    folder: Path = typer.Argument(..., help="Measurement folder (tyre.toml) or a single "
                                            "characteristics CSV."),
    base: Path | None = typer.Option(None, "--base", help="Base model .tir: its "
                                        "coefficients define the base; every library "
                                        "coefficient at its neutral value is a candidate."),
    base_form: str | None = typer.Option(None, "--base-form", help="Named base form "
                                            "(RR/old, CMz/T1, CFy/linear_load, "
                                            "CFx/linear_load, camber/no_pressure, or a form "
                                            "from --candidates)."),
    candidates: Path | None = typer.Option(None, "--candidates", help="TOML file with "
                                              "more candidate effects, in the format of "
                                              "identify/discover/library.toml (an entry with "
                                              "a shipped name replaces it)."),
    alpha: float = typer.Option(0.05, "--alpha", help="Family-wise significance level "
                                                      "(Holm) of each step."),
    out: Path | None = typer.Option(None, "--out", help="Output folder (default "
                                       "fits/<tyre id>/discovery/)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the multi-start base fits."),
    starts: int = typer.Option(1, "--starts", help="Base-fit starts per problem (1: local "
                                                   "fit from the base values)."),
    max_steps: int = typer.Option(4, "--max-steps", help="Most effects added per problem."),
    only: list[str] = typer.Option([], "--only", help="Problems to analyse (names or "
                                   "patterns: MF, MF/Fy, CFy, RR, camber/*); repeatable."),
    heldout: str = typer.Option("auto", "--heldout", help="Held-out scheme: auto (leave "
                                "one pressure out when pressure is crossed with load, else "
                                "k-fold within condition cells), pressure, cells or rows."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Only the conclusion."),
) -> None:
    """Score every candidate effect of the library on the base fit (projected LM test),
    add the best, refit, and keep it only when the F test and the held-out error agree;
    repeat until nothing passes. Prints the plain conclusion; writes discovery.json,
    discovery.pdf, the enriched .tir and fit.json.
    """

    try:
        if not 0.0 < alpha < 1.0:
            raise InputError(None, f"alpha must lie in (0, 1), not {alpha:g}", key="--alpha")
        if starts < 1 or max_steps < 1:
            raise InputError(None, "--starts and --max-steps must be >= 1")
        if heldout not in SCHEMES:
            raise InputError(None, f"unknown held-out scheme {heldout!r}; choose from "
                                   f"{', '.join(SCHEMES)}", key="--heldout")
        settings = Settings(alpha=alpha, seed=seed, n_starts=starts, max_steps=max_steps,
                            heldout=heldout)
        patterns = tuple(p.strip() for item in only for p in item.split(",") if p.strip())
        with StageProgress(err_console) if not quiet else nullcontext() as say:
            run = discover_folder(folder, base_tir=base, base_form=base_form,
                                  candidates=candidates, settings=settings, out_dir=out,
                                  only=patterns, command=shlex.join(sys.argv), progress=say)
    except MfidError as exc:
        fail(exc)
    d = run.discovery
    if not quiet:
        for note in run.notes:
            err_console.print(f"note: {note}", markup=False)
        for p in d.problems:
            reads = list(p.upstream)
            err_console.print(f"{p.name}: error {p.base_error_pct:.3g} % -> "
                              f"{p.final_error_pct:.3g} %, noise floor "
                              f"{p.noise_floor_pct:.3g} % ({p.floor_source}); "
                              f"{p.noise.kind} noise; held out: {p.heldout_scheme}; "
                              f"{len(p.candidates)} candidate(s)"
                              + (f", uses the coefficients of {', '.join(reads)}" if reads
                                 else ""),
                              markup=False)
    out_console.print(d.conclusion, markup=False)
    if not quiet:
        out_console.print(f"wrote {run.json_path}, {run.pdf_path.name}, {run.tir_path.name}, "
                          f"{run.fit_json_path.name}", markup=False)
