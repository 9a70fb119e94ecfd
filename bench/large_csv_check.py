"""Benchmark: ``mfid check`` of a folder holding one 5-million-sample trailer CSV.

Generates the CSV (13 channels, ~450 MB, the signals of bench/load.py) and its tyre.toml in
/tmp (kept for reuse: ``--keep``), then runs ``mfid check`` in a child process and reports its
wall time and peak resident memory (ru_maxrss of the child, from resource.getrusage).
Targets (issue 15): <= 20 s and <= 1 GB. Timings are noisy on a shared machine: run twice.

    .venv/bin/python bench/large_csv_check.py [--samples 5000000] [--folder /tmp/mfid-5M]
"""
from __future__ import annotations

import argparse
import resource
import subprocess
import sys
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5_000_000)
    parser.add_argument("--folder", type=Path, default=Path("/tmp/mfid-5M"))
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    folder = write_folder(args.folder, args.samples)
    size = (folder / "trailer.csv").stat().st_size / 1e6
    print(f"folder {folder}: {args.samples} samples, {size:.0f} MB "
          f"({time.perf_counter() - t0:.1f} s to prepare)")
    mfid = Path(sys.executable).parent / "mfid"
    start = time.perf_counter()
    result = subprocess.run([str(mfid), "check", str(folder)], capture_output=True, text=True)
    wall = time.perf_counter() - start
    peak_gb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024 / 1e9  # KiB
    print((result.stdout + result.stderr).strip()[:400])
    print(f"mfid check: exit {result.returncode}, {wall:.1f} s (target {TARGET_S:.0f} s), "
          f"peak RSS {peak_gb:.2f} GB (target {TARGET_GB:.0f} GB)")
    return 0 if result.returncode == 0 and wall <= TARGET_S and peak_gb <= TARGET_GB else 1


if __name__ == "__main__":
    sys.exit(main())
