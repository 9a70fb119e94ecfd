"""Fit benchmarks (issue 5, acceptance 6; issue 46).

1. Wall time of the full fit of the bundled sample folder without MCMC (target <= 60 s on the
   2-core project machine).
2. Effective MCMC samples per second for the CFy relation on the thesis characteristics
   (target >= 1000 effective samples in <= 30 s).
3. ``--real DIR``: a real session (a folder of TTC files, e.g. ../shared/realdata/<set>)
   imported, then ``mfid fit`` with its report in one process (``--workers 1``) against two
   (``--workers 2``), in one run: wall and CPU times of each, their ratio, and whether the
   .tir, measured_vs_model.csv and the numbers of fit.json are identical (they must be).
   Issue 46 asks at most 60 s wall on 2 cores for a session of about 100,000 samples.

    python bench/fit.py [--folder measurements/sample-225-50R17]
    nice python bench/fit.py --real ../shared/realdata/ttc_r2_b1052_hoosier_20.5x7.0-13
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import shlex  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from identify.fit.mcmc.chains import run_mcmc  # noqa: E402
from identify.fit.optimize import fit  # noqa: E402
from identify.fit.relations import problems as R  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402
from identify.model.parameters import defaults  # noqa: E402
from identify.workflows.fit import FitSettings, fit_folder  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _timed(cmd: list[str]) -> tuple[float, float]:
    """Run ``cmd``; (wall, CPU user + system of it and its children) [s]. A failed command
    stops the benchmark with its output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode not in (0, 1):  # 1: a stage FAILED, outputs written all the same
        raise SystemExit(f"{shlex.join(cmd)} exited {p.returncode}:\n{p.stdout}\n{p.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _numbers(fit_json: Path) -> dict:
    """fit.json without what differs between two runs of the same fit (times, the command,
    the creation time)."""
    def strip(v):
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items()
                    if k not in ("seconds", "command", "elapsed") and not k.startswith("created")}
        if isinstance(v, list):
            return [strip(x) for x in v]
        return v
    return strip(json.loads(fit_json.read_text()))


def real_session(folder: Path) -> None:
    """Benchmark 3 (see module) on the TTC files of ``folder``."""
    exe = str(Path(sys.executable).with_name("mfid"))
    files = sorted(str(f) for f in folder.iterdir()
                   if f.suffix.lower() in (".mat", ".dat", ".csv"))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        wall, _ = _timed([exe, "import", *files, "--out", str(work / "set")])
        print(f"{folder.name}: import {wall:.1f} s")
        runs = {}
        for name, extra in (("one process", ["--workers", "1"]),
                            ("two processes", ["--workers", "2"])):
            out, reports = work / name.replace(" ", "-"), work / f"{name}-reports".replace(" ", "-")
            wall, cpu = _timed([exe, "fit", str(work / "set"), "--out", str(out),
                                "--reports", str(reports), *extra])
            runs[name] = (wall, cpu, next(out.iterdir()))
            print(f"  mfid fit + report, {name:15s}: {wall:6.1f} s wall, {cpu:6.1f} s CPU")
        (w1, _, d1), (w2, _, d2) = runs["one process"], runs["two processes"]
        same = (all((d1 / f.name).read_bytes() == f.read_bytes()
                    for f in d2.iterdir() if f.suffix in (".tir", ".csv"))
                and _numbers(d1 / "fit.json") == _numbers(d2 / "fit.json"))
        print(f"  wall ratio one process / two processes: {w1 / w2:.2f}; outputs "
              f"{'identical' if same else 'DIFFERENT'}; issue 46 target <= 60 s wall "
              f"(two processes: {w2:.1f} s; load average now {os.getloadavg()[0]:.1f}: "
              "a ratio means something on an otherwise idle machine only)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=ROOT / "measurements" / "sample-225-50R17")
    parser.add_argument("--real", type=Path, action="append", default=[], metavar="DIR",
                        help="a folder of real TTC files: benchmark 3 only (repeatable)")
    args = parser.parse_args()
    if args.real:
        for folder in args.real:
            real_session(folder)
        return
    with tempfile.TemporaryDirectory() as tmp:
        stages: list[tuple[str, float]] = []

        def progress(text: str) -> None:
            now = time.perf_counter()
            stages.append((text, now))

        t0 = time.perf_counter()
        run = fit_folder(args.folder, out_root=tmp, settings=FitSettings(seed=0),
                         progress=progress)
        total = time.perf_counter() - t0
        print(f"full fit of {args.folder.name} without MCMC: {total:.1f} s "
              f"(target <= 60 s) -> {len(run.results)} fits")
        marks = stages + [("end", time.perf_counter())]
        for (name, t_a), (_, t_b) in zip(marks, marks[1:]):
            print(f"  {t_b - t_a:6.2f} s  {name}")
    thesis = load_folder(ROOT / "measurements" / "thesis-225-50R17")
    t = {k: float(v) for k, v in defaults().items() if isinstance(v, (int, float))}
    ctx = R.Context(5000.0, 2.5, t)
    problem = R.cfy(thesis.characteristics, ctx, form="linear_load")
    result = fit(problem)
    t0 = time.perf_counter()
    sampled = run_mcmc(problem, result, seed=0)
    dt = time.perf_counter() - t0
    m = sampled.mcmc
    print(f"MCMC, CFy linear_load on the thesis data: {m.n_samples} effective samples in "
          f"{dt:.1f} s = {m.n_samples / dt:.0f} per second (target >= 1000 in <= 30 s); "
          f"tau max {max(m.tau.values()):.0f} steps, acceptance {m.acceptance:.2f}, "
          f"{m.n_walkers} walkers x {m.n_steps} steps")


if __name__ == "__main__":
    main()
