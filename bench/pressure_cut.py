"""A pressure cut out of a real session, predicted by the fit of the other pressures.

For every set of real trailer files (the sub-folders of ``../shared/realdata`` from the
repository root that hold trailer files; ``--sets DIR ...`` for others) whose loaded samples
hold at least three pressure levels (bench/realdata.py's :func:`pressure_levels`), this

1. imports the files with ``mfid import`` into a scratch folder;
2. for each interior level (the lowest and highest are not cut: that would be extrapolation,
   which the pressure terms are not asked to do) or the levels given with ``--levels``,
   removes the level's samples (those nearest to it) from the loaded table, fits the rest in
   this process with the default pipeline (:func:`identify.workflows.fit.fit_measurements`),
   and evaluates the fitted .tir on every loaded sample with a positive load;
3. reports, per force and moment, the pooled error 100 RMS(model - measured) / RMS(measured)
   on the cut level's samples and on the fitted levels' samples, and their ratio (the
   acceptance: at most 1.25).

The cut is made on the loaded table, after the import: the nominal pressure and load of the
tyre are the full session's (the import of a folder without the level could choose another
middle level as NOMPRES; the fit's pressure terms are relative to it either way).

    nice python bench/pressure_cut.py                     # every set with 3+ levels
    python bench/pressure_cut.py --sets DIR --levels 70   # a level [kPa] of one set

The table goes to stdout and, with the records, to bench/results/pressure_cut.{md,json}
(git-ignored); scratch files to a temporary folder (removed unless ``--keep``). Nothing is
written when no set is found.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("MPLBACKEND", "Agg")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import math  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import realdata as RD  # noqa: E402

RESULTS = RD.RESULTS
CHANNELS = ("Fx", "Fy", "Mz", "Mx")
LIMIT = 1.25
"""The acceptance: the cut level's error at most this many times the fitted levels'."""


def interior(levels: Sequence[float]) -> list[float]:
    """The levels strictly between the lowest and the highest."""
    return sorted(levels)[1:-1]


def cut_levels(levels: Sequence[float], wanted_kpa: Sequence[float] | None) -> list[float]:
    """The levels [Pa] to cut: each ``wanted_kpa`` [kPa] matched to the nearest level, else
    every interior level."""
    if not wanted_kpa:
        return interior(levels)
    lv = np.asarray(levels, float)
    return [float(lv[np.argmin(np.abs(lv - w * 1e3))]) for w in wanted_kpa]


def judge_cut(mset, table, inputs, ok, level_idx, levels, k, say) -> dict:
    """Fit ``mset`` without the samples of level ``k`` and evaluate on every sample."""
    from identify.fit.run import FitSettings
    from identify.workflows.fit import fit_measurements
    cut = level_idx == k
    t0 = time.perf_counter()
    run = fit_measurements(dataclasses.replace(mset, trailer=table[~cut].reset_index(drop=True)),
                           settings=FitSettings(pressure_holdout=False))
    seconds = time.perf_counter() - t0
    params = {n: float(v) for n, v in run.tir_values.items() if isinstance(v, (int, float))}
    model = RD.predict(params, inputs)
    rec = {"level_kPa": levels[k] / 1e3, "cut_samples": int((cut & ok).sum()),
           "seconds": seconds, "failed": list(run.failed), "cut": {}, "fitted": {},
           "ratio": {}}
    for c in CHANNELS:
        if c not in inputs.columns:
            continue
        meas = inputs[c].to_numpy(float)
        e_cut = RD.rms_pct(meas[cut & ok], model[c][cut & ok])
        e_fit = RD.rms_pct(meas[~cut & ok], model[c][~cut & ok])
        rec["cut"][c], rec["fitted"][c] = e_cut, e_fit
        rec["ratio"][c] = e_cut / e_fit if e_fit and math.isfinite(e_fit) else math.nan
    say(f"  cut {levels[k] / 1e3:.1f} kPa ({rec['cut_samples']} samples, {seconds:.0f} s): "
        + ", ".join(f"{c} {rec['cut'][c]:.2f} / {rec['fitted'][c]:.2f} % "
                    f"({rec['ratio'][c]:.2f}x)" for c in rec["cut"]))
    return rec


def judge_set(folder: Path, work: Path, wanted_kpa, say) -> dict:
    rec: dict = {"set": folder.name, "files": [p.name for p in RD.trailer_files(folder)]}
    _wall, failed, mset, table, inputs, ok = RD.import_set(folder, work)
    if failed:
        rec["skipped"] = failed
        return rec
    p = table["p"].to_numpy(float)
    levels = RD.pressure_levels(p)
    rec["levels_kPa"] = [lv / 1e3 for lv in levels]
    if len(levels) < 3:
        rec["skipped"] = f"{len(levels)} pressure level(s): 3 needed for an interior cut"
        return rec
    idx = RD.nearest_level(p, levels)
    say(f"{folder.name}: levels " + ", ".join(f"{lv / 1e3:.1f}" for lv in levels) + " kPa")
    rec["cuts"] = [judge_cut(mset, table, inputs, ok, idx, levels, levels.index(lv), say)
                   for lv in cut_levels(levels, wanted_kpa)]
    return rec


def table_md(recs: Sequence[dict]) -> str:
    lines = ["| set | cut [kPa] | samples | " + " | ".join(
        f"{c} cut / fitted % (ratio)" for c in CHANNELS) + " |",
        "|---|---|---|" + "---|" * len(CHANNELS)]
    for r in recs:
        if "skipped" in r:
            lines.append(f"| {r['set']} | - | - | skipped: {r['skipped']} |")
            continue
        for c in r["cuts"]:
            cells = [f"{c['cut'][ch]:.2f} / {c['fitted'][ch]:.2f} ({c['ratio'][ch]:.2f}x)"
                     if ch in c["cut"] else "-" for ch in CHANNELS]
            lines.append(f"| {r['set']} | {c['level_kPa']:.1f} | {c['cut_samples']} | "
                         + " | ".join(cells) + " |")
    return "\n".join(lines) + f"\n\nAcceptance: the cut level's error at most {LIMIT}x the " \
                              "fitted levels' (Fy, Mz, Fx).\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", nargs="+", metavar="DIR", help="folders of trailer files")
    ap.add_argument("--levels", nargs="+", type=float, metavar="KPA",
                    help="levels to cut [kPa] (default: every interior level)")
    ap.add_argument("--work", type=Path, help="scratch folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of pressure_cut.{md,json}")
    a = ap.parse_args(argv)
    sets = RD.sets_to_judge(a.sets, "pressure_cut")
    if not sets:
        return 0 if sets is not None else 2
    work = a.work or Path(tempfile.mkdtemp(prefix="mfid-pressure-cut-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        recs = [judge_set(s, work, a.levels, lambda t: print(t, flush=True)) for s in sets]
    finally:
        if not a.keep and a.work is None:
            shutil.rmtree(work, ignore_errors=True)
    RD.write_results(a.out, "pressure_cut", table_md(recs), recs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
