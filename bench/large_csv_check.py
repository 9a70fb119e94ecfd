"""Benchmark: ``mfid check`` (and ``mfid fit --only MF``) of a folder holding one
5-million-sample trailer CSV.

Generates the CSV (13 channels, ~650 MB, the signals of bench/load.py) and its tyre.toml in
/tmp (kept for reuse), then runs ``mfid check`` in a child process and reports its wall time,
CPU time (user + system) and peak resident memory (ru_maxrss of that child, what
``/usr/bin/time -v`` prints as "Maximum resident set size"). With ``--fit`` it then runs
``mfid fit FOLDER --only MF`` (outputs in a temporary folder, removed) and reports the same
numbers. Targets (issue 15): check <= 20 s and <= 1 GB; the fit finishes (exit 0, every
output written). Timings are noisy on a shared machine: compare the CPU time, and run twice.

    .venv/bin/python bench/large_csv_check.py [--samples 5000000] [--folder /tmp/mfid-5M]
                                              [--fit [--fit-nice 5]]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.load import NAMES, channels  # noqa: E402

TARGET_S, TARGET_GB = 20.0, 1.0
TOML = """[tyre]
id = "bench-5M"
nominal_pressure_Pa = 250000
nominal_load_N = 5000
unloaded_radius_m = 0.32

[[runs]]
file = "trailer.csv"
kind = "trailer"
test = "cornering"
units = { SLIPANGL = "deg", INFLPRES = "kPa" }
"""


def write_folder(folder: Path, samples: int) -> Path:
    """The folder with tyre.toml and trailer.csv (written in blocks of 500,000 rows)."""
    folder.mkdir(parents=True, exist_ok=True)
    csv = folder / "trailer.csv"
    if csv.is_file() and (folder / "size").is_file() and \
            (folder / "size").read_text() == str(samples):
        return folder
    data = channels(samples)
    block = 500_000
    with open(csv, "w") as fh:
        fh.write(",".join(NAMES) + "\n")
        for start in range(0, samples, block):
            rows = np.column_stack([data[n][start:start + block] for n in NAMES])
            np.savetxt(fh, rows, fmt="%.9g", delimiter=",")
    (folder / "tyre.toml").write_text(TOML)
    (folder / "size").write_text(str(samples))
    return folder


def measure(argv: list[str]) -> tuple[subprocess.CompletedProcess, float, float, float]:
    """Run ``argv`` in a child process: (result, wall [s], CPU [s], peak RSS [GB]).

    The child runs alone in a fresh ``python -c`` wrapper so that ru_maxrss of the children
    of that wrapper is the command's own peak, not the largest of several commands."""
    code = ("import resource, subprocess, sys, time\n"
            "start = time.perf_counter()\n"
            "rc = subprocess.run(sys.argv[1:]).returncode\n"
            "wall = time.perf_counter() - start\n"
            "ru = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
            "print(f'{rc} {wall} {ru.ru_utime + ru.ru_stime} {ru.ru_maxrss}', file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True)
    *lines, last = result.stderr.rstrip().splitlines() or ["1 0 0 0"]
    rc, wall, cpu, kib = last.split()
    result = subprocess.CompletedProcess(argv, int(rc), result.stdout, "\n".join(lines))
    return result, float(wall), float(cpu), int(kib) * 1024 / 1e9


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5_000_000)
    parser.add_argument("--folder", type=Path, default=Path("/tmp/mfid-5M"))
    parser.add_argument("--fit", action="store_true", help="also run mfid fit --only MF")
    parser.add_argument("--fit-nice", type=int, default=0, metavar="N",
                        help="run the fit under `nice -n N` (a machine shared with others)")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    folder = write_folder(args.folder, args.samples)
    size = (folder / "trailer.csv").stat().st_size / 1e6
    print(f"folder {folder}: {args.samples} samples, {size:.0f} MB "
          f"({time.perf_counter() - t0:.1f} s to prepare)")
    mfid = str(Path(sys.executable).parent / "mfid")
    result, wall, cpu, peak_gb = measure([mfid, "check", str(folder)])
    print((result.stdout + result.stderr).strip()[:400])
    print(f"mfid check: exit {result.returncode}, {wall:.1f} s wall, {cpu:.1f} s CPU (target "
          f"{TARGET_S:.0f} s), peak RSS {peak_gb:.2f} GB (target {TARGET_GB:.0f} GB)")
    ok = result.returncode == 0 and wall <= TARGET_S and peak_gb <= TARGET_GB
    if args.fit:
        with tempfile.TemporaryDirectory(prefix="mfid-5M-fit-") as tmp:
            nice = ["nice", "-n", str(args.fit_nice)] if args.fit_nice else []
            fit, wall, cpu, peak_gb = measure([*nice, mfid, "fit", str(folder), "--only", "MF",
                                               "--out", f"{tmp}/fits", "--reports",
                                               f"{tmp}/reports"])
            written = sorted(p.name for p in Path(tmp).rglob("*") if p.is_file())
        print(f"mfid fit --only MF: exit {fit.returncode}, {wall:.1f} s wall, {cpu:.1f} s CPU, "
              f"peak RSS {peak_gb:.2f} GB; wrote {', '.join(written) or 'nothing'}")
        ok = ok and fit.returncode == 0
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
