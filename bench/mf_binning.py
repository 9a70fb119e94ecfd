"""Effect of sweep binning (identify.workflows.sweep_bins) on the MF stages: time, coefficients.

Fits the same trailer table twice, as sampled and binned (both with the runs that hold a
warm-up segmented, as ``mfid fit`` does), and prints per stage the points, the
wall time and, for every coefficient free in both fits, the difference binned - sampled in
standard errors of the sampled fit (|z| < 1: within its standard error).

    python bench/mf_binning.py --trailer table.pkl --fnomin 4980 --nompres 256600 --r0 0.3255
    python bench/mf_binning.py            # the bundled sample folder

The table is a pickled trailer table (pandas ``to_pickle`` of ``load_folder(...).trailer``), as
for bench/fit_cost.py.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from fit_cost import FOLDER, start_values  # noqa: E402

from identify.fit.mf.stages import fit_mf  # noqa: E402
from identify.fit.run import BIN_ALPHA_DEG, BIN_KAPPA  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402
from identify.segment import SegmentSettings  # noqa: E402
from identify.workflows.sweep_bins import mf_table  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trailer", type=Path)
    ap.add_argument("--fnomin", type=float)
    ap.add_argument("--nompres", type=float)
    ap.add_argument("--r0", type=float)
    ap.add_argument("--alpha-deg", type=float, default=BIN_ALPHA_DEG)
    ap.add_argument("--kappa", type=float, default=BIN_KAPPA)
    args = ap.parse_args()
    if args.trailer:
        trailer = pd.read_pickle(args.trailer)
        fnomin, nompres, r0 = args.fnomin, args.nompres, args.r0
    else:
        mset = load_folder(FOLDER)
        trailer, t = mset.trailer, mset.manifest.tyre
        fnomin, nompres, r0 = t.nominal_load_N, t.nominal_pressure_Pa, t.unloaded_radius_m
    base = start_values(fnomin, nompres, r0)
    # both as mfid fit selects the points (logged runs segmented), with and without binning
    binned, _ = mf_table(trailer, fnomin, segment=True, settings=SegmentSettings(
        bin_alpha_deg=args.alpha_deg, bin_kappa=args.kappa))
    trailer, _ = mf_table(trailer, fnomin, segment=True, settings=SegmentSettings())
    fits = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for name, table in (("sampled", trailer), ("binned", binned)):
            t0 = time.perf_counter()
            fits[name] = (fit_mf(table, base), time.perf_counter() - t0)
    a, ta = fits["sampled"]
    b, tb = fits["binned"]
    print(f"{len(trailer)} samples -> {len(binned)} binned (alpha {args.alpha_deg:g} deg, "
          f"kappa {args.kappa:g}); MF stages {ta:.1f} s sampled, {tb:.1f} s binned")
    for ra in a.results:
        try:
            rb = b.result(ra.form)
        except KeyError:
            continue
        common = [n for n in ra.free if n in rb.free]
        z = {n: (rb.parameters[n] - ra.parameters[n]) / ra.stderr[n] for n in common
             if ra.stderr[n] > 0}
        worst = max(z, key=lambda n: abs(z[n])) if z else "-"
        within = sum(abs(v) < 1 for v in z.values())
        print(f"{ra.form:8} points {ra.n_points:6d} -> {rb.n_points:5d}  time "
              f"{ra.seconds:6.1f} -> {rb.seconds:5.1f} s  free {len(ra.free)}/{len(rb.free)}  "
              f"|z| < 1: {within}/{len(z)}  worst {worst} "
              f"{z.get(worst, np.nan):+.2f}  error % {ra.error_total_pct:.2f} -> "
              f"{rb.error_total_pct:.2f}")
        only = sorted(set(ra.free) ^ set(rb.free))
        if only:
            print(f"         free in one fit only: {', '.join(only)}")


if __name__ == "__main__":
    main()
