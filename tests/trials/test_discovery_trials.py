"""Issue 7 and 19 acceptance trials for ``mfid discover`` (run with ``make trials`` or
``pytest -m trials tests/trials``). About 1650 trials; well under an hour on two cores.

1. >= 6 hidden effects (PPY5, QSY8, PPY1, PPX1, PPMX1, PCFY2 among them), 50 randomised trials
   each: first named in >= 95 % (independent 1 % noise) and >= 80 % (AR(1), rho = 0.9).
2. >= 200 null trials per noise model: a false addition in <= 5 % (independent), <= 10 % (AR(1)).
3. When named: training and held-out error both drop; excess error explained >= 80 % (median).
4. A confusion matrix with Wilson intervals is printed.
5. Scoring all candidates takes no longer than one base fit.
6. Issue 19: a confounded rolling-resistance table (five load/pressure pairs, QSY7 and QSY8
   hidden, 1 % noise), 50 seeds: both named in >= 90 %; 200 null tables: a false addition in
   <= 5 %; the printed noise floor of every table is at most the final error.
"""
from __future__ import annotations

import json

import pytest

from tests.bench_modules import load_bench

N_TRIALS = 50
N_NULL = 200


@pytest.mark.trials
def test_discovery_trials(tmp_path, capsys):
    bench = load_bench("discovery_trials")
    records = bench.run(N_TRIALS, N_NULL, jobs=2)
    s = bench.summarise(records)
    text = bench.table(s)
    (tmp_path / "discovery_trials.json").write_text(json.dumps(
        {"summary": s, "records": records}, default=float))
    with capsys.disabled():
        print("\n" + text)
    effects = {k.split("|")[0] for k in s["named"]}
    assert len(effects) >= 6 and set(bench.REQUIRED) <= effects
    assert f"{bench.CONFOUNDED}|confounded" in s["named"] and "confounded" in s["null"]
    tables = [r for r in records if r["scenario"] == "RR/confounded"]
    assert all(r["floor"] <= r["final_error"] + 1e-12 for r in tables)
    for key, v in s["named"].items():
        noise = key.split("|")[1]
        assert v["n"] >= N_TRIALS
        assert v["rate"] >= bench.TARGET_NAMED[noise], (key, v)
        d = s["drops"][key]
        assert d["both_drop"] == d["n_named"], (key, d)
        assert d["ee_median"] >= 0.8, (key, d)
    for noise, v in s["null"].items():
        assert v["n"] >= N_NULL
        assert v["rate"] <= bench.TARGET_NULL[noise], (noise, v)
    assert s["timing"]["score_over_fit_median"] <= 1.0
    assert s["timing"]["score_over_fit_p95"] <= 1.0
