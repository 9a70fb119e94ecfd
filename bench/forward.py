"""Forward-model throughput: full combined evaluation (all outputs), MF 6.1, useMode 111.

Measures points per second for the pure-numpy reference path and the fused numba kernel at
1e4, 1e5 and 1e6 points on ONE core (thread pools pinned to 1), best of several repeats, and
prints them next to the scale given in the issue: MFeval (vectorised MATLAB) under GNU Octave
evaluates about 2.3e5 points/s on this machine type; the target is 10x that (2.3e6 points/s).
The last column runs the fused kernel on all cores (numba threads) for comparison.

    python bench/forward.py [--repeats 5] [--json out.json] [--profile]

``--profile`` says where the kernel's time goes: it times each libm function the kernel calls
(ns per call, in a compiled loop) and multiplies by how often the kernel calls it per point
(counted from identify/model/kernel.py for the general combined-slip path, useMode 111).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from identify.io.tir import read_tir  # noqa: E402
from identify.model.evaluate import evaluate  # noqa: E402
from identify.model.kernel import evaluate_fused  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TIR = ROOT / "tests" / "data" / "tir" / "testA_61.tir"
OCTAVE_MFEVAL_PTS_PER_S = 2.3e5
TARGET_PTS_PER_S = 2.3e6


def _points(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(1000, 9000, n), rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.2, n),
            rng.uniform(-0.1, 0.1, n), rng.uniform(5, 35, n), rng.uniform(1.8e5, 3.2e5, n))


def _best_rate(fn, P, pts, repeats: int, **kw) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(P, *pts[:5], p=pts[5], mode=111, **kw)
        best = min(best, time.perf_counter() - t0)
    return pts[0].size / best


# Transcendental calls per point in the fused kernel (general combined-slip point, mode 111):
# atan: Fx0 2, Gxa 4, Fy0 3 + Fy0(gamma=0) 3, SVyk 1, Gyk 4, Et 1, alpha_eq 2, t 2, Mx 3, Re 1
CALLS_PER_POINT = {"atan": 26, "sin": 7, "cos": 7, "tan": 4, "pow": 3, "exp": 1}


def _summing_loop(fn):
    """A compiled loop that sums fn(v[i]) over an array (timing one libm function)."""
    import numba

    inner = numba.njit(fn)

    @numba.njit
    def loop(v):
        s = 0.0
        for i in range(v.size):
            s += inner(v[i])
        return s
    return loop


def _ns_per_element(loop, x) -> float:
    loop(x[:10])  # compile
    t0 = time.perf_counter()
    loop(x)
    return (time.perf_counter() - t0) / x.size * 1e9


def _libm_profile(total_ns_per_point: float) -> None:
    import math

    x = np.random.default_rng(0).uniform(0.1, 3.0, 2_000_000)
    functions = {"atan": lambda v: math.atan(v), "sin": lambda v: math.sin(v),
                 "cos": lambda v: math.cos(v), "tan": lambda v: math.tan(v),
                 "pow": lambda v: v ** 0.85, "exp": lambda v: math.exp(v)}
    base = _ns_per_element(_summing_loop(lambda v: v * 1.0001), x)  # loop and add overhead
    print(f"\nwhere the fused kernel's time goes ({total_ns_per_point:.0f} ns per point):")
    spent = 0.0
    for name, fn in functions.items():
        ns = _ns_per_element(_summing_loop(fn), x) - base
        part = ns * CALLS_PER_POINT[name]
        spent += part
        print(f"  {name:>5}: {ns:5.1f} ns/call x {CALLS_PER_POINT[name]:>2} calls = "
              f"{part:6.0f} ns/point ({100 * part / total_ns_per_point:4.1f} %)")
    print(f"  libm transcendental calls in all: {spent:.0f} ns/point "
          f"({100 * spent / total_ns_per_point:.0f} % of the kernel); the rest is arithmetic, "
          "branches, the Re fixed point and memory traffic")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--profile", action="store_true", help="say where the time goes")
    args = parser.parse_args()
    P = read_tir(TIR).params()
    warm = _points(100)
    t0 = time.perf_counter()
    evaluate_fused(P, *warm[:5], p=warm[5])  # compile (or load from the numba cache)
    compile_s = time.perf_counter() - t0
    rows = []
    print(f"fused kernel first call (compile or cache load): {compile_s:.2f} s")
    evaluate_fused(P, *warm[:5], p=warm[5], threads=True)
    print(f"{'points':>9} {'numpy pts/s':>13} {'fused pts/s':>13} {'fused/numpy':>11} "
          f"{'fused/Octave':>12} {'fused/target':>12} {'all cores':>11}")
    for n in (10_000, 100_000, 1_000_000):
        pts = _points(n)
        reps = args.repeats if n < 1_000_000 else max(2, args.repeats // 2)
        r_np = _best_rate(evaluate, P, pts, reps)
        r_fu = _best_rate(evaluate_fused, P, pts, reps)
        r_mt = _best_rate(evaluate_fused, P, pts, reps, threads=True)
        rows.append({"points": n, "numpy_pts_per_s": r_np, "fused_pts_per_s": r_fu,
                     "fused_all_cores_pts_per_s": r_mt})
        print(f"{n:>9} {r_np:>13.3g} {r_fu:>13.3g} {r_fu / r_np:>11.2f} "
              f"{r_fu / OCTAVE_MFEVAL_PTS_PER_S:>12.2f} {r_fu / TARGET_PTS_PER_S:>12.2f} "
              f"{r_mt:>11.3g}")
    if args.profile:
        _libm_profile(1e9 / rows[-1]["fused_pts_per_s"])
    if args.json:
        args.json.write_text(json.dumps({"compile_s": compile_s, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
