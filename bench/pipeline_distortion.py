"""What the sample pipeline does to a characteristic: the truth .tir against noise-free points.

A generated TTC session without noise (``simulate_ttc(..., noise=0)``: drift, load ripple,
warm-ups and logging quirks as usual) is imported as bench/ttc_truth.py does, and its trailer
table goes through :func:`identify.workflows.trailer_prep.prepare_trailer` four ways: with
and without the revolution average, with and without the sweep binning. At every point the
truth .tir is evaluated at the point's own inputs (load, slip, camber, speed, pressure, all
averaged as the forces are); what is left is what the averaging did to the characteristic,
which the fit then absorbs into the coefficients. Printed per way and quantity: the RMS of
measured - truth relative to the RMS of the truth [%] and its mean with the sign of the truth
(a systematic pull towards or away from zero) [%], on the pure-slip points (Fx: |alpha| < 0.5
deg; Fy, Mz: |kappa| < 0.005).

    python bench/pipeline_distortion.py --seeds 0 1 [--keep DIR] [--tir FILE]

Measured 2026-11-25, seed 1 (docs/intervals.md, "What the averaging does"): the raw samples
are exact (0.0000 %); the revolution average alone leaves Fx 0.057 %, Fy 0.023 %, Mz 0.091 %
RMS, the binning alone 0.006 / 0.010 / 0.030 %, both 0.047 / 0.020 / 0.073 %.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import tempfile  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from identify.fit.run import BIN_ALPHA_DEG, BIN_KAPPA  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402
from identify.io.tir import read_tir  # noqa: E402
from identify.model.evaluate import evaluate  # noqa: E402
from identify.model.modes import FIT_MODE  # noqa: E402
from identify.segment import SegmentSettings  # noqa: E402
from identify.simulate import default_tir_path  # noqa: E402
from identify.simulate.ttc import simulate_ttc  # noqa: E402
from identify.workflows.import_session import import_session  # noqa: E402
from identify.workflows.trailer_prep import prepare_trailer  # noqa: E402

WAYS = {
    "revolution average + bins (mfid fit)": dict(bin_alpha_deg=BIN_ALPHA_DEG,
                                                 bin_kappa=BIN_KAPPA),
    "bins only": dict(bin_alpha_deg=BIN_ALPHA_DEG, bin_kappa=BIN_KAPPA,
                      revolution_average=False),
    "revolution average only": dict(bin_alpha_deg=None, bin_kappa=None),
    "raw samples": dict(bin_alpha_deg=None, bin_kappa=None, revolution_average=False),
}
PURE = {"Fx": ("alpha", np.deg2rad(0.5)), "Fy": ("kappa", 0.005), "Mz": ("kappa", 0.005)}
"""Quantity -> the slip that must be near zero for a pure-slip point, and how near."""


def distortion(where: Path, seed: int, tir: Path | None = None
               ) -> dict[str, dict[str, tuple[float, float]]]:
    """Per way and quantity: (RMS, signed mean) of measured - truth over RMS truth [%];
    ``tir``: the truth (default the bundled tyre)."""
    truth_tir = read_tir(tir or default_tir_path()).params()
    simulate_ttc(truth_tir, where / "ttc", seed=seed, noise=0.0, overwrite=True)
    truth = {k: float(v) for k, v in
             json.loads((where / "ttc" / "truth.json").read_text())["tir"].items()
             if isinstance(v, (int, float))}
    imp = import_session(sorted((where / "ttc").glob("*.mat")), where / "folder",
                         overwrite=True, nominal_pressure_Pa=truth["NOMPRES"],
                         unloaded_radius_m=truth["UNLOADED_RADIUS"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mset = load_folder(imp.path)
    out = {}
    for way, kw in WAYS.items():
        t = prepare_trailer(mset, SegmentSettings(**kw)).table
        cols = [t[c].to_numpy(float) for c in ("Fz", "kappa", "alpha", "gamma", "Vx")]
        model = evaluate(truth, *cols, p=t["p"].to_numpy(float), mode=FIT_MODE)
        out[way] = {}
        for q, (slip, near) in PURE.items():
            measured = t[q].to_numpy(float)
            m = (np.abs(t[slip].to_numpy(float)) < near) & np.isfinite(measured)
            r, b = measured[m] - model[q][m], model[q][m]
            scale = float(np.sqrt(np.mean(b ** 2)))
            out[way][q] = (100 * float(np.sqrt(np.mean(r ** 2))) / scale,
                           100 * float(np.mean(r * np.sign(b))) / scale)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--keep", type=Path, default=None, help="keep the folders here")
    ap.add_argument("--tir", type=Path, default=None,
                    help="the truth .tir (default: the bundled 225/50 R17 tyre)")
    args = ap.parse_args()
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            where = (args.keep / f"seed{seed}") if args.keep else Path(tmp)
            res = distortion(where, seed, args.tir)
        print(f"seed {seed}: measured - truth on noise-free points, RMS (signed mean) [%]")
        for way, qs in res.items():
            print(f"  {way:38s} " + "  ".join(f"{q} {rms:.4f} ({mean:+.4f})"
                                               for q, (rms, mean) in qs.items()))


if __name__ == "__main__":
    main()
