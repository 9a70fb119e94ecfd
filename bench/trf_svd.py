"""Does the QR route of scipy's trf SVD (identify.fit.solve.trf_svd) pay? The MF stages with it
and without it, in one run.

The MF stage fit of a folder's trailer table (``fit_mf`` on the table ``mfid fit`` bins, from
MFeval start values) runs ``--rounds`` times with the QR route (the default: the MF solves'
tolerances set ``qr_svd``) and as often with scipy's own SVD (``trf_svd.PATCHABLE`` switched off
for the round), alternately, so that a load that drifts biases neither. Printed and written to
bench/results/trf_svd.md: the CPU seconds of each round, the ratio of the sums (without / with,
above 1 when the route pays) and the largest relative difference of a fitted coefficient between
the two routes (the same steps to round-off, so the same optimum).

    python bench/trf_svd.py [--folder measurements/sample-225-50R17] [--rounds 3]

Runs on one BLAS thread.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

from identify.fit.mf.stages import fit_mf  # noqa: E402
from identify.fit.run import FitSettings  # noqa: E402
from identify.fit.solve import trf_svd  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402
from identify.model.parameters import defaults  # noqa: E402
from identify.workflows.sweep_bins import mf_table, segment_settings  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"


def stage_table(folder: Path):
    """The binned trailer table and start values ``mfid fit`` gives the MF stages."""
    mset = load_folder(folder)
    tyre = mset.manifest.tyre
    base = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    base["FNOMIN"] = float(tyre.nominal_load_N)
    base["NOMPRES"] = base["INFLPRES"] = float(tyre.nominal_pressure_Pa)
    if tyre.unloaded_radius_m:
        base["UNLOADED_RADIUS"] = float(tyre.unloaded_radius_m)
    s = FitSettings()
    table, _ = mf_table(mset.trailer, base["FNOMIN"], segment=s.segment,
                        settings=segment_settings(s))
    return table, base


def one_fit(table, base, qr: bool):
    """CPU seconds of one fit_mf and its fitted values, with or without the QR route."""
    saved = trf_svd.PATCHABLE
    trf_svd.PATCHABLE = saved and qr
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            c0 = time.process_time()
            mf = fit_mf(table, base)
            cpu = time.process_time() - c0
    finally:
        trf_svd.PATCHABLE = saved
    return cpu, {k: float(v) for k, v in mf.params.items() if not isinstance(v, str)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folder", type=Path, default=ROOT / "measurements" / "sample-225-50R17")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    if not trf_svd.PATCHABLE:
        raise SystemExit("the installed scipy's trf is not patchable: nothing to compare")
    table, base = stage_table(args.folder)
    one_fit(table, base, True)  # warm-up: compiled kernels, JAX traces, caches
    cpu = {True: [], False: []}
    values = {}
    for r in range(args.rounds):
        for qr in ((True, False) if r % 2 == 0 else (False, True)):
            t, v = one_fit(table, base, qr)
            cpu[qr].append(t)
            values[qr] = v
            print(f"round {r + 1} {'qr route ' if qr else 'scipy svd'}: {t:.2f} s CPU", flush=True)
    ratio = sum(cpu[False]) / sum(cpu[True])
    diff = max((abs(values[True][k] - values[False][k]) / max(abs(values[False][k]), 1e-12)
                for k in values[True] if k in values[False]), default=float("nan"))
    lines = [
        f"# trf_svd: {args.folder.name}, fit_mf, {args.rounds} rounds each, one BLAS thread",
        "",
        f"- CPU s with the QR route: {', '.join(f'{t:.2f}' for t in cpu[True])}",
        f"- CPU s with scipy's svd:  {', '.join(f'{t:.2f}' for t in cpu[False])}",
        f"- ratio scipy svd / QR route (sums): {ratio:.3f}",
        f"- largest relative difference of a fitted coefficient: {diff:.2e}",
        f"- load average at the end: {os.getloadavg()[0]:.2f}",
    ]
    print("\n".join(lines))
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "trf_svd.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
