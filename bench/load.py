"""Benchmark: load a 1e6-sample trailer file (CSV and HDF5) into the tidy ISO-W table.

Writes the files to a temporary directory, then times :func:`identify.io.trailer.files.read_trailer`
(format detection, parsing, unit conversion, checks, tidy table) on each. Target: < 2 s each.

    .venv/bin/python bench/load.py [--samples N] [--repeat R]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from identify.io.hdf5.channel_files import RawRun, write_hdf5  # noqa: E402
from identify.io.trailer.files import read_trailer  # noqa: E402

NAMES = ("RUNTIME", "LONGVEL", "WHROTSPD", "SLIPANGL", "LONGSLIP", "INCLANGL", "INFLPRES",
         "FX", "FYW", "FZW", "MXW", "MYW", "MZW")
TARGET_S = 2.0


def channels(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """A long slip-angle sweep with noise, ISO-W, SI (SLIPANGL in deg to exercise units)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 1000.0
    alpha = 0.2 * np.sin(2 * np.pi * t / 60.0)
    noise = rng.normal(size=(6, n))
    return {
        "RUNTIME": t, "LONGVEL": 16.7 + 0.01 * noise[0], "WHROTSPD": 16.7 / 0.31 + 0.0 * t,
        "SLIPANGL": np.degrees(alpha), "LONGSLIP": 0.001 * noise[1], "INCLANGL": 0.0 * t,
        "INFLPRES": 250.0 + 0.5 * noise[2], "FX": -60.0 + 5 * noise[3],
        "FYW": -6000.0 * np.tanh(alpha / 0.08) + 20 * noise[4],
        "FZW": 5000.0 + 30 * noise[5], "MXW": 250.0 * np.tanh(alpha / 0.08),
        "MYW": -60.0 + 0.0 * t, "MZW": 90.0 * np.sin(3 * np.arctan(alpha / 0.05)),
    }


def _time(path: Path, repeat: int, **kwargs) -> list[float]:
    out = []
    for _ in range(repeat):
        start = time.perf_counter()
        frame = read_trailer(path, **kwargs)
        out.append(time.perf_counter() - start)
        assert len(frame) > 0
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    data = channels(args.samples)
    units = {"SLIPANGL": "deg", "INFLPRES": "kPa"}
    results = []
    with tempfile.TemporaryDirectory(prefix="mfid-bench-") as tmp:
        tmp = Path(tmp)
        table = np.column_stack([data[k] for k in NAMES])
        header = ",".join(NAMES)
        for label, fmt in (("CSV, 10 significant digits", "%.10g"),
                           ("CSV, 17 significant digits", "%.17g")):
            path = tmp / f"sweep_{fmt[2:4]}.csv"
            start = time.perf_counter()
            np.savetxt(path, table, fmt=fmt, delimiter=",", header=header, comments="")
            print(f"(wrote {label}: {path.stat().st_size / 1e6:.0f} MB in "
                  f"{time.perf_counter() - start:.1f} s)")
            results.append((label, path, _time(path, args.repeat, units=units)))
        path = tmp / "sweep.h5"
        write_hdf5(path, [RawRun("sweep", data, {k: units.get(k, "") for k in NAMES})])
        print(f"(wrote HDF5: {path.stat().st_size / 1e6:.0f} MB)")
        results.append(("HDF5", path, _time(path, args.repeat)))
    print(f"\nload {args.samples:.0e} samples x {len(NAMES)} channels -> tidy table "
          f"(best of {args.repeat}; target < {TARGET_S} s)")
    ok = True
    for label, _, times in results:
        best = min(times)
        ok &= best < TARGET_S
        print(f"  {label:<28} best {best:6.3f} s   first {times[0]:6.3f} s   "
              f"{'ok' if best < TARGET_S else 'SLOW'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
