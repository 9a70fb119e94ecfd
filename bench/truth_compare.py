"""The fitted .tir against the simulator's truth (issue 18, acceptance 1 and 3).

1. ``truth``: fit simulated folders (the bundled sample and ``mfid simulate default DIR --seed
   N`` folders) and compare the written .tir with truth.json over the measured operating range
   (identify.workflows.truth_compare: Fx, Fy, Mz, Mx within 1 %, Cx, Cy, Cz, CMz, sigma_y
   within 2 %, RMS relative to the truth's RMS).
2. ``forms``: simulate -> extract -> fit CFx and CFy on seeds with the quadratic-load term on
   and off (CFx p2 = -0.28 by default, off with ``--hide CFx.p2=0``; CFy p2 = 0 by default, on
   with ``--hide CFy.p2=-0.2``) and count the form the .tir takes.

    python bench/truth_compare.py truth [--seeds 2 3] [--sample] [--jobs 2]
    python bench/truth_compare.py forms [--seeds 0 ... 19] [--jobs 2]

Each folder is simulated in a temporary directory; ``--keep DIR`` keeps them.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

import pandas as pd  # noqa: E402

from identify.io.tir import read_tir  # noqa: E402
from identify.simulate import default_tir_path, simulate_folder  # noqa: E402
from identify.workflows.fit import FitSettings, fit_folder  # noqa: E402
from identify.workflows.truth_compare import compare_to_truth  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "measurements" / "sample-225-50R17"
QUADRATIC = {"CFx": -0.280917, "CFy": -0.2}
"""p2 of each relation with the quadratic-load term on."""
OFF = {"CFx.p2": 0.0, "CFy.p2": -0.2}
"""--hide for the second simulation of a seed: CFx linear, CFy quadratic."""


def compare_folder(folder: Path, out: Path, seed: int = 0, only: tuple[str, ...] = ()):
    """Fit ``folder`` into ``out`` and compare its .tir with the folder's truth.json."""
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        run = fit_folder(folder, out_root=out, settings=FitSettings(seed=seed, only=only,
                                                                  pressure_holdout=False))
    seconds = time.perf_counter() - t0
    truth = json.loads((folder / "truth.json").read_text())["tir"]
    points = pd.read_csv(run.csv_path)
    return run, compare_to_truth(read_tir(run.tir_path).params(), truth, points), seconds


def _simulate(seed: int, where: Path, hide: dict | None = None) -> Path:
    folder = where / f"sim-seed{seed}{'-hidden' if hide else ''}"
    simulate_folder(read_tir(default_tir_path()).params(), folder, seed=seed, hide=hide,
                    overwrite=True)
    return folder


def truth_trial(seed: int | None, where: str) -> dict:
    """One folder (``seed`` None: the bundled sample): the comparison as a dict."""
    where = Path(where)
    folder = SAMPLE if seed is None else _simulate(seed, where)
    run, cmp, seconds = compare_folder(folder, where / "fits", seed=0)
    return {"folder": folder.name, "seconds": seconds, "ok": cmp.ok, "table": cmp.table(),
            "quantities": {q.name: {"rms_pct": q.rms_pct, "max_pct": q.max_pct,
                                    "tolerance_pct": q.tolerance_pct, "ok": q.ok}
                           for q in cmp.quantities},
            "forms": {c.relation: c.form for c in run.form_choices},
            "poorly_identified": list(run.poorly_identified)}


def forms_trial(seed: int, where: str) -> list[dict]:
    """Both simulations of one seed (default; CFx off and CFy on), fitted for CFx and CFy:
    the written form of each with whether the term was on."""
    where = Path(where)
    out = []
    for hide in (None, OFF):
        folder = _simulate(seed, where, hide)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            run = fit_folder(folder, out_root=where / "fits",
                             settings=FitSettings(seed=seed, only=("CFx", "CFy")))
        for c in run.form_choices:
            on = (hide or {}).get(f"{c.relation}.p2", 0.0 if c.relation == "CFy" else
                                  QUADRATIC["CFx"]) != 0.0
            out.append({"seed": seed, "relation": c.relation, "quadratic_on": on,
                        "form": c.form, "p_value": c.p_value, "reason": c.reason})
    return out


def _in_pool(trial, items, names, jobs: int, keep: str | None) -> list:
    """``trial(item, folder)`` for every item in a process pool, each in its own folder
    (below ``keep``, or a temporary folder removed afterwards)."""
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(keep or tmp)
        dirs = [str(base / name) for name in names]
        for d in dirs:
            Path(d).mkdir(parents=True, exist_ok=True)
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            return list(pool.map(trial, items, dirs))


def run_truth(seeds, sample: bool, jobs: int, keep: str | None) -> list[dict]:
    items = ([None] if sample else []) + list(seeds)
    names = [f"truth-{'sample' if s is None else s}" for s in items]
    return _in_pool(truth_trial, items, names, jobs, keep)


def run_forms(seeds, jobs: int, keep: str | None) -> list[dict]:
    rows = _in_pool(forms_trial, seeds, [f"forms-{s}" for s in seeds], jobs, keep)
    return [r for trial_rows in rows for r in trial_rows]


def forms_summary(records: list[dict]) -> dict[str, dict]:
    """relation|on or off -> {n, right, form wanted}."""
    out: dict[str, dict] = {}
    for r in records:
        key = f"{r['relation']}|{'on' if r['quadratic_on'] else 'off'}"
        want = "quadratic_load" if r["quadratic_on"] else "linear_load"
        s = out.setdefault(key, {"n": 0, "right": 0, "want": want})
        s["n"] += 1
        s["right"] += r["form"] == want
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("truth", "forms"))
    parser.add_argument("--seeds", type=int, nargs="*", default=None)
    parser.add_argument("--sample", action="store_true",
                        help="truth: also the bundled sample folder")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--keep", default=None, help="keep the simulated folders here")
    args = parser.parse_args()
    t0 = time.perf_counter()
    if args.what == "truth":
        seeds = [2, 3] if args.seeds is None else args.seeds
        for rec in run_truth(seeds, args.sample, args.jobs, args.keep):
            print(f"\n{rec['folder']}: {'ok' if rec['ok'] else 'MISSED'} "
                  f"(fit {rec['seconds']:.0f} s; forms {rec['forms']})")
            print(rec["table"])
    else:
        seeds = list(range(20)) if args.seeds is None else args.seeds
        records = run_forms(seeds, args.jobs, args.keep)
        for key, s in forms_summary(records).items():
            print(f"{key:8s} {s['want']:15s} {s['right']}/{s['n']}")
        for r in records:
            print(f"  seed {r['seed']:3d} {r['relation']} on={r['quadratic_on']!s:5} "
                  f"{r['form']:15s} p={r['p_value']:.2g}")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
