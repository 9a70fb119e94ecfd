"""Benchmark: extract every characteristic of the bundled sample folder (issue 4, acceptance 4).

Times :func:`identify.extract.extract_folder` on the loaded sample folder
(measurements/sample-225-50R17: 735 Flatplank runs, 5 pressures x 3 loads) and, separately,
loading the folder (:func:`identify.io.folder.load_folder`). Target: extraction < 10 s.

    .venv/bin/python bench/extract.py [--folder PATH] [--repeat R]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from identify.extract import extract_folder  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 10.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=ROOT / "measurements" / "sample-225-50R17")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    loads, extracts = [], []
    for _ in range(args.repeat):
        start = time.perf_counter()
        measurement = load_folder(args.folder)
        loads.append(time.perf_counter() - start)
        start = time.perf_counter()
        result = extract_folder(measurement)
        extracts.append(time.perf_counter() - start)
    runs = len(measurement.manifest.runs)
    print(f"{args.folder.name}: {runs} runs, {len(measurement.flatplank)} Flatplank samples")
    print(f"  {result.summary()}")
    print(f"  load    best {min(loads):6.2f} s  (all: {', '.join(f'{t:.2f}' for t in loads)})")
    print(f"  extract best {min(extracts):6.2f} s  (all: {', '.join(f'{t:.2f}' for t in extracts)})"
          f"  target < {TARGET_S:g} s")
    print(f"  load + extract best {min(a + b for a, b in zip(loads, extracts)):.2f} s")
    ok = min(extracts) < TARGET_S
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
