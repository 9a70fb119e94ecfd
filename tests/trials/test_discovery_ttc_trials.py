"""Issue 19 acceptance 3: discovery on TTC-style sessions generated with
``mfid simulate --format ttc`` (bench/discovery_ttc.py; run with ``pytest -m trials``).

A base .tir without pressure terms (the bundled tyre, every MF pressure term at zero):

- PPY1 and PPY3 hidden in the data (the bundled tyre's values), 20 seeds: both named in
  >= 18/20;
- nothing hidden, the generator's drift, warm-ups and temperature trends on, 20 seeds: no
  false addition (a tyre effect; the drift nuisance absorbing the drift is not one) in
  >= 18/20.

Each session is ~136k samples through simulate, import and ``discover --only MF``: hours on a
loaded two-core machine.
"""
from __future__ import annotations

import json

import pytest

from tests.bench_modules import load_bench

N_SEEDS = 20


@pytest.mark.trials
def test_discovery_ttc_sessions(tmp_path, capsys):
    bench = load_bench("discovery_ttc")
    records = bench.run(N_SEEDS, jobs=2)
    (tmp_path / "discovery_ttc.json").write_text(json.dumps(records, indent=1))
    with capsys.disabled():
        print("\n" + bench.table(records))
    hidden = [r for r in records if r["set"] == "hidden"]
    null = [r for r in records if r["set"] == "null"]
    assert len(hidden) == len(null) == N_SEEDS
    assert sum(r["named"] for r in hidden) >= bench.TARGET
    assert sum(not r["false_addition"] for r in null) >= bench.TARGET
