"""Fit cost of the Magic Formula stages in forward-evaluation equivalents.

For every MF stage of ``mfid fit`` on a measurement folder's trailer data: the stage's fit wall
time divided by the time of one full forward evaluation (every output, useMode 211, the numpy
reference path ``identify.model.evaluate.evaluate``) of the same points, both measured in this
run, so that the ratio does not depend on how fast or busy the machine is. The total is the MF
stages' wall time over one evaluation of all their points. The yardstick is the numpy path in
every version, so ratios of different versions compare the fits, not the kernels.

    python bench/fit_cost.py [--folder DIR] [--json out.json]

Runs on the code of the checkout it is in (also an older one: it falls back to the old module
paths), on one BLAS thread.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from identify.fit.mf_stages import fit_mf  # noqa: E402
from identify.model.evaluate import evaluate  # noqa: E402
from identify.model.parameters import defaults  # noqa: E402

try:
    from identify.io.folder import load_folder  # noqa: E402
except ImportError:  # versions before the io layer
    from identify.load.folder import load_folder  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "measurements" / "sample-225-50R17"
REPEATS = 5


def start_values(mset) -> dict[str, float]:
    """Where ``mfid fit`` starts: MFeval defaults with the folder's nominal conditions."""
    base = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    tyre = mset.manifest.tyre
    base["FNOMIN"] = float(tyre.nominal_load_N)
    base["NOMPRES"] = base["INFLPRES"] = float(tyre.nominal_pressure_Pa)
    if tyre.unloaded_radius_m:
        base["UNLOADED_RADIUS"] = float(tyre.unloaded_radius_m)
    return base


def evaluation_seconds(params: dict, points) -> float:
    """Best of REPEATS wall times of one full forward evaluation of ``points`` [s]."""
    cols = {c: points[c].to_numpy(float) for c in ("Fz", "kappa", "alpha", "gamma", "Vx", "p")}
    omega = points["omega"].to_numpy(float) if "omega" in points else None
    best = np.inf
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        evaluate(params, cols["Fz"], cols["kappa"], cols["alpha"], cols["gamma"], cols["Vx"],
                 p=cols["p"], omega=omega, mode=211)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--folder", type=Path, default=FOLDER)
    ap.add_argument("--json", type=Path, help="write the numbers to this file")
    args = ap.parse_args()
    mset = load_folder(args.folder)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        t0 = time.perf_counter()
        mf = fit_mf(mset.trailer, start_values(mset))
        total_fit = time.perf_counter() - t0
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    print(f"{args.folder.name} at {commit}: {len(mset.trailer)} trailer samples; "
          f"yardstick: numpy evaluate(), all outputs, useMode 211, best of {REPEATS}")
    print(f"{'stage':9} {'points':>7} {'fit s':>8} {'eval ms':>8} {'fit/eval':>9} {'nfev':>7}")
    rows, all_eval = [], 0.0
    for r in mf.results:
        pts = mf.points[r.form]
        t_eval = evaluation_seconds(mf.params, pts)
        all_eval += t_eval
        nfev = int(getattr(r, "nfev", 0))
        rows.append({"stage": r.form, "points": int(len(pts)), "fit_s": r.seconds,
                     "eval_s": t_eval, "ratio": r.seconds / t_eval, "nfev": nfev})
        print(f"{r.form:9} {len(pts):7d} {r.seconds:8.2f} {1e3 * t_eval:8.2f} "
              f"{r.seconds / t_eval:9.0f} {nfev or '':>7}")
    print(f"{'total':9} {sum(x['points'] for x in rows):7d} {total_fit:8.2f} "
          f"{1e3 * all_eval:8.2f} {total_fit / all_eval:9.0f}")
    if args.json:
        args.json.write_text(json.dumps({"folder": str(args.folder), "commit": commit,
                                         "stages": rows, "total_fit_s": total_fit,
                                         "total_eval_s": all_eval,
                                         "total_ratio": total_fit / all_eval}, indent=1))


if __name__ == "__main__":
    main()
