"""Batch throughput (issue 16, acceptance 3 and 4): N simulated folders fitted one after another
with `mfid fit` (as `make fits` without -j) against `mfid batch --workers W`, back to back in
one run; then a second `mfid batch` that has nothing to do, and a third after one number of
one folder's input changed (only that folder is refitted).

    python bench/batch.py [--folders 8] [--workers 2] [--only CFx,CFz,CMz,camber,sidewall]
                          [--rounds 1] [--dask] [--keep DIR]

Prints each wall time, the ratio batch / sequential, and the load average before and after
(the machine may be shared: compare the ratio, not the seconds), and the CPU seconds of each
(every process of the run, workers included), whose ratio does not depend on the load. With
``--rounds R`` the pair is measured R times, the order alternating (sequential first, then batch
first) so that a load that drifts during the run biases neither; the ratio of the sums is
printed last. Every run uses one BLAS thread per process, as `make fits` does.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import psutil  # with the dask extra (mfid[test] pulls it)

from identify.io.tir import read_tir
from identify.simulate import default_tir_path, simulate_folder

MFID = Path(sys.executable).parent / "mfid"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
       "MKL_NUM_THREADS": "1", "MPLBACKEND": "Agg"}


CPU_S = [0.0]
"""CPU seconds of every mfid process tree timed so far (:func:`timed` adds to it)."""


def _tree_cpu(proc: psutil.Process, seen: dict[int, float]) -> None:
    """Record the CPU seconds (user + system, its own) of ``proc`` and its descendants."""
    try:
        family = [proc, *proc.children(recursive=True)]
    except psutil.Error:
        return
    for p in family:
        try:
            t = p.cpu_times()
            seen[p.pid] = t.user + t.system
        except psutil.Error:
            pass


def timed(args: list[str], cwd: Path, out: list[str] | None = None) -> float:
    """Wall time of ``mfid ARGS`` [s]; its stdout lines go to ``out`` when given. The CPU
    seconds of the process and of its workers (sampled every 0.2 s, so up to 0.2 s of each
    process's last moments is missed) are added to :data:`CPU_S`."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([str(MFID), *args], cwd=cwd, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    seen: dict[int, float] = {}
    root = psutil.Process(proc.pid)
    reader = ThreadPoolExecutor(1).submit(proc.communicate)
    while not reader.done():
        _tree_cpu(root, seen)
        time.sleep(0.2)
    stdout, stderr = reader.result()
    wall = time.perf_counter() - t0
    CPU_S[0] += sum(seen.values())
    if proc.returncode not in (0, 1):
        sys.exit(f"failed ({proc.returncode}): mfid {' '.join(args)}\n{stderr}")
    if out is not None:
        out.extend(stdout.splitlines())
    return wall


def cpu_since(start: float) -> str:
    return f"CPU {CPU_S[0] - start:.1f} s"


def change_one_number(folder: Path) -> Path:
    """Change one number of the last Flatplank run of ``folder`` (a bench copy); its path."""
    run = sorted((folder / "flatplank").iterdir())[-1]
    lines = run.read_text().splitlines()
    lines[2] = lines[2].replace(",", ",1", 1)
    run.write_text("\n".join(lines) + "\n")
    return run


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()) + \
        f" on {os.cpu_count()} cores"


def sequential(r: int, names: list[str], root: Path, workers: int, fit_opts: list[str]
               ) -> float:
    """`mfid fit` of every folder, one after another [s]."""
    c0 = CPU_S[0]
    t = sum(timed(["fit", name, "--out", f"round{r}/seq/fits", "--reports",
                   f"round{r}/seq/reports", *fit_opts], root) for name in names)
    print(f"round {r + 1}: sequential mfid fit x {len(names)}: {t:.1f} s, {cpu_since(c0)}  "
          f"({load()})", flush=True)
    return t


def pool(r: int, names: list[str], root: Path, workers: int, fit_opts: list[str]) -> float:
    """One `mfid batch --workers W` of every folder [s]."""
    c0 = CPU_S[0]
    t = timed(["batch", *names, "--out", f"round{r}/pool/fits", "--reports",
               f"round{r}/pool/reports", "--workers", str(workers), *fit_opts], root)
    print(f"round {r + 1}: mfid batch --workers {workers}: {t:.1f} s, {cpu_since(c0)}  "
          f"({load()})", flush=True)
    return t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folders", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", default="CFx,CFz,CMz,camber,sidewall",
                        help="relations to fit ('' for the whole fit, MF stages included)")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--dask", action="store_true", help="also --scheduler local")
    parser.add_argument("--keep", type=Path, help="work here instead of a temporary folder")
    args = parser.parse_args()
    fit_opts = ["--only", args.only] if args.only else []
    with tempfile.TemporaryDirectory() as tmp:
        root = args.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        tir = read_tir(default_tir_path()).params()
        names = [f"b{i}" for i in range(1, args.folders + 1)]
        for i, name in enumerate(names, start=1):
            if not (root / name / "tyre.toml").is_file():
                simulate_folder(tir, root / name, seed=i, grid="small", tyre_id=name)
        print(f"{args.folders} small simulated folders, fit options {fit_opts or 'all'}, "
              f"reports on", flush=True)
        print(f"before: {load()}", flush=True)
        wall = {"sequential": 0.0, "pool": 0.0}
        cpu = {"sequential": 0.0, "pool": 0.0}
        for r in range(args.rounds):
            order = (sequential, pool) if r % 2 == 0 else (pool, sequential)
            times = {}
            for run in order:
                c0 = CPU_S[0]
                times[run.__name__] = run(r, names, root, args.workers, fit_opts)
                wall[run.__name__] += times[run.__name__]
                cpu[run.__name__] += CPU_S[0] - c0
            print(f"round {r + 1}: ratio batch / sequential "
                  f"{times['pool'] / times['sequential']:.2f}", flush=True)
        print(f"all rounds: sequential {wall['sequential']:.1f} s, batch {wall['pool']:.1f} s, "
              f"ratio {wall['pool'] / wall['sequential']:.2f}", flush=True)
        # on a loaded machine the wall times measure the share of the cores each run got; the
        # CPU seconds do not depend on it: with W idle cores the batch would take at least
        # its CPU / W, the sequential fits their CPU (one process at a time)
        print(f"all rounds: CPU sequential {cpu['sequential']:.1f} s, batch {cpu['pool']:.1f} s;"
              f" batch CPU / {args.workers} over sequential CPU "
              f"{cpu['pool'] / args.workers / cpu['sequential']:.2f} (the ratio on "
              f"{args.workers} idle cores if the workers stay busy)", flush=True)
        again = timed(["batch", *names, "--out", "round0/pool/fits", "--reports",
                       "round0/pool/reports",
                       "--workers", str(args.workers), *fit_opts], root)
        print(f"second mfid batch, nothing changed: {again:.1f} s", flush=True)
        changed = change_one_number(root / names[0])
        lines: list[str] = []
        one = timed(["batch", *names, "--out", "round0/pool/fits", "--reports",
                     "round0/pool/reports", "--workers", str(args.workers), *fit_opts], root,
                    lines)
        refitted = [m.group(1) for m in map(re.compile(r"failed: (\S+): ok \(").search, lines)
                    if m]
        print(f"third mfid batch, {changed.relative_to(root)} changed: {one:.1f} s, refitted "
              f"{', '.join(refitted) or 'nothing'}  ({load()})", flush=True)
        if args.dask:
            dask = timed(["batch", *names, "--out", "dask/fits", "--reports", "dask/reports",
                          "--workers", str(args.workers), "--scheduler", "local", *fit_opts],
                         root)
            print(f"mfid batch --scheduler local --workers {args.workers}: {dask:.1f} s  "
                  f"({load()})", flush=True)


if __name__ == "__main__":
    main()
