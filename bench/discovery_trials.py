"""Discovery trials (issues 7, 19): hidden effects and null data, independent and AR(1) noise, and
a confounded design with two effects that only generalise together.

Each trial generates one problem directly from the model on its test matrix
(:mod:`identify.discover.scenarios`: random base coefficients, effect sign and size, seed), runs
:func:`identify.discover.search.discover` with the shipped library, and records what was named.
The summary prints, per hidden effect and noise model, the rate at which the hidden effect is
the first one named (Wilson 95 % interval), the false-addition rate on null data, the
training/held-out error drops and the excess error explained, a confusion matrix (hidden vs
first named) and the scoring time against one base-fit time.

The confounded set (issue 19; :func:`identify.discover.scenarios.make_confounded`): a
rolling-resistance table of five load/pressure pairs at four speeds, QSY7 and QSY8 both hidden,
independent 1 % noise; "named" means both are accepted (as one block or one after the other),
its null trials have nothing hidden. ``--heldout pressure`` forces leave-one-pressure-out folds
(the scheme of issue 19), to see the joint blocks at work.

Usage::

    python bench/discovery_trials.py [--trials 50] [--null 200] [--jobs 2] [--json out.json]
    python bench/discovery_trials.py --only-confounded [--heldout pressure]
    python bench/discovery_trials.py --power 20     # power against effect size instead
    python bench/discovery_trials.py --jsonl part.jsonl   # each record as it arrives
    python bench/discovery_trials.py --summarise part.jsonl   # summarise a run stopped early
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from identify.discover.scenarios import EFFECTS, SCENARIOS, make_confounded, make_problem  # noqa: E402

NOISE = {"independent": 0.0, "ar1": 0.9}
GROUPS = ("independent", "ar1", "confounded")
REQUIRED = ("PPY5", "QSY8", "PPY1", "PPX1", "PPMX1", "PCFY2")
TARGET_NAMED = {"independent": 0.95, "ar1": 0.80, "confounded": 0.90}
TARGET_NULL = {"independent": 0.05, "ar1": 0.10, "confounded": 0.05}
CONFOUNDED = "QSY7+QSY8"


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k/n."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def run_one(task: tuple) -> dict:
    """One trial: (scenario, hidden or None, noise name, seed[, value]) -> record."""
    from identify.discover.library import load_library
    from identify.discover.search import Settings, discover

    scenario, hidden, noise, seed, *rest = task
    value = rest[0] if rest else None
    heldout = rest[1] if len(rest) > 1 else "auto"
    rng = np.random.default_rng(seed)
    if scenario == "RR/confounded":
        problem, truth = make_confounded(rng, hidden is not None)
    else:
        problem, truth = make_problem(scenario, rng, hidden, value, rho=NOISE[noise])
    t0, c0 = time.perf_counter(), time.process_time()
    d = discover([problem], load_library(), Settings(seed=seed, heldout=heldout))
    p = d.problems[0]
    first = d.accepted[0] if d.accepted else None
    named = None if first is None else (
        "ambiguous" if first.ambiguous_with else first.name)
    if scenario == "RR/confounded" and first is not None:
        keys = {k for a in d.accepted if not a.ambiguous_with for k in a.coefficients}
        named = CONFOUNDED if keys >= {"QSY7", "QSY8"} else "+".join(sorted(keys)) or named
    return {"scenario": scenario, "hidden": hidden, "noise": noise, "seed": seed,
            "value": truth["value"], "named": named, "n_added": len(d.accepted),
            "added": [a.name for a in d.accepted],
            "error_before": None if first is None else first.error_before_pct,
            "error_after": None if first is None else first.error_after_pct,
            "heldout_before": None if first is None else first.heldout_before_pct,
            "heldout_after": None if first is None else first.heldout_after_pct,
            "excess_explained": None if first is None else (
                p.excess_explained if scenario == "RR/confounded" else first.excess_explained),
            "floor": p.noise_floor_pct, "final_error": p.final_error_pct,
            "noise_model": p.noise.kind, "phi": p.noise.phi,
            "fit_seconds": p.fit_seconds, "score_seconds": p.score_seconds,
            "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}


def tasks(n_trials: int, n_null: int, effects, seed0: int = 1000,
          confounded: bool = True, heldout: str = "auto", standard: bool = True) -> list[tuple]:
    """Every trial; each noise model, each effect and the confounded set get their own seeds.
    The sets are interleaved (the first trial of every set, then the second ...), so a run
    stopped early (``--jsonl``) holds a balanced part of every set."""
    sets = []
    for j, noise in enumerate(NOISE if standard else ()):
        base = seed0 + 100_000 * j
        for k, e in enumerate(effects):
            sets.append([(EFFECTS[e][0], e, noise, base + 1000 * k + i)
                         for i in range(n_trials)])
        sets.append([(SCENARIOS[i % len(SCENARIOS)], None, noise, base + 50_000 + i)
                     for i in range(n_null)])
    if confounded:
        base = seed0 + 300_000
        sets.append([("RR/confounded", CONFOUNDED, "confounded", base + i, None, heldout)
                     for i in range(n_trials)])
        sets.append([("RR/confounded", None, "confounded", base + 50_000 + i, None, heldout)
                     for i in range(n_null)])
    # null sets have 4x the trials: take 4 of theirs per round so all sets end together
    per_round = [max(1, round(len(t) / max(n_trials, 1))) for t in sets]
    out = []
    for r in range(max((len(t) + k - 1) // k for t, k in zip(sets, per_round))):
        for t, k in zip(sets, per_round):
            out += t[r * k:(r + 1) * k]
    return out


POWER_EFFECTS = ("PPX1", "QSY8", "PCFY2")
POWER_FRACTIONS = (0.05, 0.1, 0.25, 0.5, 1.0)


def power(n: int, jobs: int = 2) -> str:
    """Rate of naming the hidden effect against its size (fractions of the trials' smallest
    size), both noise models: a table."""
    todo = []
    for j, noise in enumerate(NOISE):
        for e in POWER_EFFECTS:
            lo = EFFECTS[e][1]
            neutral = 1.0 if e == "QSY7" else 0.0
            for f in POWER_FRACTIONS:
                todo += [(EFFECTS[e][0], e, noise, 7_000_000 + 100_000 * j + i,
                          neutral + (1 if i % 2 else -1) * f * lo) for i in range(n)]
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        recs = list(ex.map(run_one, todo, chunksize=4))
    lines = ["power: effect | noise | |deviation| | named/n | rate | Wilson 95 %"]
    for noise in NOISE:
        for e in POWER_EFFECTS:
            for f in POWER_FRACTIONS:
                size = f * EFFECTS[e][1]
                rs = [r for r in recs if r["hidden"] == e and r["noise"] == noise
                      and abs(abs(r["value"] - (1.0 if e == "QSY7" else 0.0)) - size) < 1e-12]
                k = sum(r["named"] == e for r in rs)
                lo, hi = wilson(k, len(rs))
                lines.append(f"{e:6s} | {noise:11s} | {size:.4g} | {k}/{len(rs)} | "
                             f"{k / max(len(rs), 1):.2f} | [{lo:.2f}, {hi:.2f}]")
    return "\n".join(lines)


def run(n_trials: int = 50, n_null: int = 200, jobs: int = 2, effects=None,
        confounded: bool = True, heldout: str = "auto", standard: bool = True,
        jsonl: str | None = None) -> list[dict]:
    """Every trial's record; with ``jsonl``, each record is also appended to that file as it
    arrives (one JSON object a line), so a run stopped early can be summarised."""
    todo = tasks(n_trials, n_null, effects or list(EFFECTS), confounded=confounded,
                 heldout=heldout, standard=standard)
    out = []
    sink = open(jsonl, "a", encoding="utf-8") if jsonl else None
    try:
        if jobs <= 1:
            records = map(run_one, todo)
        else:
            ex = ProcessPoolExecutor(max_workers=jobs)
            records = ex.map(run_one, todo, chunksize=4)
        for rec in records:
            out.append(rec)
            if sink:
                sink.write(json.dumps(rec, default=float) + "\n")
                sink.flush()
    finally:
        if sink:
            sink.close()
        if jobs > 1:
            ex.shutdown()
    return out


def summarise(records: list[dict]) -> dict:
    """Rates with Wilson intervals, confusion matrix, error drops, timing."""
    out = {"named": {}, "null": {}, "confusion": {}, "drops": {}, "timing": {}}
    for noise in (g for g in GROUPS if any(r["noise"] == g for r in records)):
        rec = [r for r in records if r["noise"] == noise]
        for e in sorted({r["hidden"] for r in rec if r["hidden"]}):
            rs = [r for r in rec if r["hidden"] == e]
            k = sum(r["named"] == e for r in rs)
            ok = [r for r in rs if r["named"] == e]
            ee = [r["excess_explained"] for r in ok if r["excess_explained"] is not None]
            both = sum(r["error_after"] < r["error_before"]
                       and r["heldout_after"] < r["heldout_before"] for r in ok)
            out["named"][f"{e}|{noise}"] = {"k": k, "n": len(rs), "rate": k / len(rs),
                                           "ci": wilson(k, len(rs))}
            out["drops"][f"{e}|{noise}"] = {
                "both_drop": both, "n_named": len(ok),
                "ee_median": float(np.median(ee)) if ee else float("nan"),
                "ee_p10": float(np.percentile(ee, 10)) if ee else float("nan"),
                "ee_ge_0.8": float(np.mean(np.array(ee) >= 0.8)) if ee else float("nan")}
            row = {}
            for r in rs:
                row[r["named"] or "none"] = row.get(r["named"] or "none", 0) + 1
            out["confusion"][f"{e}|{noise}"] = row
        nulls = [r for r in rec if r["hidden"] is None]
        k = sum(r["n_added"] > 0 for r in nulls)
        out["null"][noise] = {"k": k, "n": len(nulls), "rate": k / max(len(nulls), 1),
                              "ci": wilson(k, len(nulls)),
                              "added": sorted({a for r in nulls for a in r["added"]})}
        row = {}
        for r in nulls:
            row[r["named"] or "none"] = row.get(r["named"] or "none", 0) + 1
        out["confusion"][f"none|{noise}"] = row
    fit = np.array([r["fit_seconds"] for r in records])
    score = np.array([r["score_seconds"] for r in records])
    out["timing"] = {"fit_median_s": float(np.median(fit)), "score_median_s": float(
        np.median(score)), "score_over_fit_max": float(np.max(score / fit)),
        "score_over_fit_median": float(np.median(score / fit)),
        "score_over_fit_p95": float(np.percentile(score / fit, 95)),
        "score_le_fit_share": float(np.mean(score <= fit)),
        "trial_median_s": float(np.median([r["seconds"] for r in records]))}
    return out


def table(s: dict) -> str:
    """The summary as plain text."""
    lines = ["hidden effect | noise | first named (k/n) | rate | Wilson 95 % | both errors drop |"
             " excess explained median (p10, share >= 0.8)"]
    for key, v in s["named"].items():
        e, noise = key.split("|")
        d = s["drops"][key]
        lines.append(f"{e:6s} | {noise:11s} | {v['k']:3d}/{v['n']:<3d} | {v['rate']:.3f} | "
                     f"[{v['ci'][0]:.3f}, {v['ci'][1]:.3f}] | {d['both_drop']}/{d['n_named']} | "
                     f"{d['ee_median']:.2f} ({d['ee_p10']:.2f}, {d['ee_ge_0.8']:.2f})")
    lines.append("")
    lines.append("null data | noise | trials with a false addition | rate | Wilson 95 % | added")
    for noise, v in s["null"].items():
        lines.append(f"none | {noise:11s} | {v['k']:3d}/{v['n']:<3d} | {v['rate']:.3f} | "
                     f"[{v['ci'][0]:.3f}, {v['ci'][1]:.3f}] | {', '.join(v['added']) or '-'}")
    lines.append("")
    cols = sorted({c for row in s["confusion"].values() for c in row})
    lines.append("confusion (rows: hidden|noise, columns: first named)")
    lines.append(f"{'':20s} " + " ".join(f"{c:>9s}" for c in cols))
    for key, row in s["confusion"].items():
        lines.append(f"{key:20s} " + " ".join(f"{row.get(c, 0):9d}" for c in cols))
    t = s["timing"]
    lines.append("")
    lines.append(f"timing: one base fit median {t['fit_median_s']:.3f} s; scoring all candidates "
                 f"median {t['score_median_s']:.4f} s (score/fit median "
                 f"{t['score_over_fit_median']:.3f}, 95th percentile "
                 f"{t['score_over_fit_p95']:.3f}, max {t['score_over_fit_max']:.3f}; score <= "
                 f"fit in {100 * t['score_le_fit_share']:.1f} % of trials); "
                 f"one trial median {t['trial_median_s']:.2f} s")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=50)
    ap.add_argument("--null", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--effects", nargs="*", default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--power", type=int, default=0, help="trials per size: power table only")
    ap.add_argument("--only-confounded", action="store_true",
                    help="only the confounded rolling-resistance set")
    ap.add_argument("--heldout", default="auto", help="held-out scheme of the confounded set")
    ap.add_argument("--jsonl", default=None,
                    help="append every record to this file as it arrives")
    ap.add_argument("--summarise", default=None, metavar="JSONL",
                    help="only summarise the records of a --jsonl file (a run stopped early)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    if args.summarise:
        with open(args.summarise, encoding="utf-8") as f:
            records = [json.loads(line) for line in f if line.strip()]
        print(table(summarise(records)))
        print(f"{len(records)} trials (from {args.summarise})")
        return 0
    if args.power:
        print(power(args.power, args.jobs))
        print(f"total {time.perf_counter() - t0:.0f} s")
        return 0
    records = run(args.trials, args.null, args.jobs, args.effects, heldout=args.heldout,
                  standard=not args.only_confounded, jsonl=args.jsonl)
    s = summarise(records)
    print(table(s))
    print(f"total {time.perf_counter() - t0:.0f} s for {len(records)} trials")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"summary": s, "records": records}, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
