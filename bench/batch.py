"""Batch throughput (issue 16, acceptance 3 and 4): N simulated folders fitted one after another
with `mfid fit` (as `make fits` without -j) against `mfid batch --workers W`, back to back in
one run; then a second `mfid batch` that has nothing to do.

    python bench/batch.py [--folders 8] [--workers 2] [--only CFx,CFz,CMz,camber,sidewall]
                          [--rounds 1] [--dask] [--keep DIR]

Prints each wall time, the ratio batch / sequential, and the load average before and after
(the machine may be shared: compare the ratio, not the seconds). With ``--rounds R`` the pair
is measured R times, the order alternating (sequential first, then batch first) so that a load
that drifts during the run biases neither; the ratio of the sums is printed last. Every run
uses one BLAS thread per process, as `make fits` does.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from identify.io.tir import read_tir
from identify.simulate import default_tir_path, simulate_folder

MFID = Path(sys.executable).parent / "mfid"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
       "MKL_NUM_THREADS": "1", "MPLBACKEND": "Agg"}


def timed(args: list[str], cwd: Path) -> float:
    t0 = time.perf_counter()
    res = subprocess.run([str(MFID), *args], cwd=cwd, env=ENV, capture_output=True, text=True)
    if res.returncode not in (0, 1):
        sys.exit(f"failed ({res.returncode}): mfid {' '.join(args)}\n{res.stderr}")
    return time.perf_counter() - t0


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()) + \
        f" on {os.cpu_count()} cores"


def sequential(r: int, names: list[str], root: Path, workers: int, fit_opts: list[str]
               ) -> float:
    """`mfid fit` of every folder, one after another [s]."""
    t = sum(timed(["fit", name, "--out", f"round{r}/seq/fits", "--reports",
                   f"round{r}/seq/reports", *fit_opts], root) for name in names)
    print(f"round {r + 1}: sequential mfid fit x {len(names)}: {t:.1f} s  ({load()})",
          flush=True)
    return t


def pool(r: int, names: list[str], root: Path, workers: int, fit_opts: list[str]) -> float:
    """One `mfid batch --workers W` of every folder [s]."""
    t = timed(["batch", *names, "--out", f"round{r}/pool/fits", "--reports",
               f"round{r}/pool/reports", "--workers", str(workers), *fit_opts], root)
    print(f"round {r + 1}: mfid batch --workers {workers}: {t:.1f} s  ({load()})", flush=True)
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
        total_seq = total_batch = 0.0
        for r in range(args.rounds):
            order = (sequential, pool) if r % 2 == 0 else (pool, sequential)
            times = {run.__name__: run(r, names, root, args.workers, fit_opts) for run in order}
            seq, batch = times["sequential"], times["pool"]
            total_seq, total_batch = total_seq + seq, total_batch + batch
            print(f"round {r + 1}: ratio batch / sequential {batch / seq:.2f}", flush=True)
        print(f"all rounds: sequential {total_seq:.1f} s, batch {total_batch:.1f} s, ratio "
              f"{total_batch / total_seq:.2f}", flush=True)
        again = timed(["batch", *names, "--out", "round0/pool/fits", "--reports",
                       "round0/pool/reports",
                       "--workers", str(args.workers), *fit_opts], root)
        print(f"second mfid batch, nothing changed: {again:.1f} s", flush=True)
        if args.dask:
            dask = timed(["batch", *names, "--out", "dask/fits", "--reports", "dask/reports",
                          "--workers", str(args.workers), "--scheduler", "local", *fit_opts],
                         root)
            print(f"mfid batch --scheduler local --workers {args.workers}: {dask:.1f} s  "
                  f"({load()})", flush=True)


if __name__ == "__main__":
    main()
