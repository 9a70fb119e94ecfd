"""All-sample error of fitted .tir files on real sessions, per channel and per kind of run.

For every set of real trailer files (the sub-folders of ``../shared/realdata`` from the
repository root that hold trailer files; ``--sets DIR ...`` for others), this imports the
files with ``mfid import``, fits the loaded set in this process for each variant (the default
pipeline, ``--no-segment``, ``--no-bin``: :func:`identify.workflows.fit.fit_measurements`) and
evaluates each fit's .tir, steady state, on every loaded sample with a positive load: the
pooled error 100 RMS(model - measured) / RMS(measured) of Fx, Fy, Mz and Mx over all samples
and over the samples of each kind of run:

``free rolling``  the runs without a slip-ratio sweep or a held slip ratio;
``drive/brake``   the other runs' samples at |alpha| < 1 deg (pure longitudinal slip);
``combined``      the other runs' samples at |alpha| >= 1 deg

(identify.fit.every_sample, which fit.json's ``every_sample`` records for the fit's own .tir). A
freely rolling run's slip-ratio channel is taken as 0, as the fit takes it.
``--tir SET=FILE`` evaluates another .tir (a published fit) on the same samples.

    nice python bench/allsample.py                           # every set, every variant
    python bench/allsample.py --sets DIR --variants default  # one set, the default only

Tables to stdout and bench/results/allsample.{md,json} (git-ignored).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Mapping, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402

import pandas as pd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import realdata as RD  # noqa: E402

VARIANTS = ("default", "no-segment", "no-bin")


def kind_errors(params: Mapping[str, float], table: pd.DataFrame) -> dict[str, dict[str, float]]:
    """Kind of run -> channel -> pooled error [%] (and ``n``, the samples): the groups ``all``
    and ``run`` of :func:`identify.fit.every_sample.every_sample`, which the fit records in
    fit.json for its own .tir."""
    from identify.fit.every_sample import every_sample
    es = every_sample(params, table)
    return {("all" if g.by == "all" else g.name): {
        **{c: e.pooled_pct for c, e in g.channels.items()}, "n": g.samples}
        for g in es.groups if g.by in ("all", "run")}


def judge_set(folder: Path, work: Path, variants: Sequence[str], tirs: Sequence[Path],
              say) -> dict:
    from identify.workflows.fit import fit_measurements
    rec: dict = {"set": folder.name, "fits": {}}
    _w, failed, mset, table, inputs, ok = RD.import_set(folder, work)
    if failed:
        rec["skipped"] = failed
        return rec
    for v in variants:
        say(f"{folder.name}: fit {v}")
        t0 = time.perf_counter()
        run = fit_measurements(mset, settings=RD.variant_settings(v))
        params = {n: float(x) for n, x in run.tir_values.items() if isinstance(x, (int, float))}
        rec["fits"][v] = {"seconds": time.perf_counter() - t0, "failed": list(run.failed),
                          "errors": kind_errors(params, table)}
    for tir in tirs:
        rec["fits"][f"tir {tir.name}"] = {"errors": kind_errors(RD._tir_params(tir), table)}
    return rec


def table_md(recs: Sequence[dict]) -> str:
    lines = []
    for r in recs:
        lines += [f"## {r['set']}", ""]
        if "skipped" in r:
            lines += [f"skipped: {r['skipped']}", ""]
            continue
        lines += ["| fit | kind | samples | " + " | ".join(RD.CHANNELS) + " |",
                  "|---|---|---|" + "---|" * len(RD.CHANNELS)]
        for name, f in r["fits"].items():
            for k, e in f["errors"].items():
                lines.append(f"| {name} | {k} | {e['n']} | "
                             + " | ".join(f"{e[c]:.2f}" for c in RD.CHANNELS if c in e) + " |")
        lines.append("")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", nargs="+", metavar="DIR")
    ap.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS))
    ap.add_argument("--tir", action="append", default=[], metavar="SET=FILE",
                    help="also evaluate this .tir on the samples of SET (repeatable)")
    ap.add_argument("--out", type=Path, default=RD.RESULTS)
    a = ap.parse_args(argv)
    sets = RD.sets_to_judge(a.sets, "allsample")
    if not sets:
        return 0 if sets is not None else 2
    tirs = RD.set_files(a.tir, "--tir", "allsample")
    if tirs is None:
        return 2
    work = Path(tempfile.mkdtemp(prefix="mfid-allsample-"))
    try:
        recs = [judge_set(s, work, a.variants, tirs.get(s.name, []),
                          lambda t: print(t, flush=True)) for s in sets]
    finally:
        shutil.rmtree(work, ignore_errors=True)
    RD.write_results(a.out, "allsample", table_md(recs), recs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
