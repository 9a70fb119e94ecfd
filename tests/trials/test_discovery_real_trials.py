"""Issue 45 acceptance on the real TTC sessions in ``../shared/realdata``
(bench/discovery_real.py; skipped when the folder is absent): on every set with two or more
pressures,

- discovery with the default base names at least one pressure coefficient of Fy;
- with the fitted .tir as base it names no pressure coefficient again;
- every pressure coefficient the fit identifies beyond 5 standard errors is testable in
  discovery (one view of the data);
- no effect is named from a base fit that did not converge.

Each set is an import, two discoveries and a fit: tens of minutes on a loaded two-core machine.
"""
from __future__ import annotations

import json

import pytest

from tests.bench_modules import load_bench

bench = load_bench("discovery_real")


@pytest.mark.trials
@pytest.mark.skipif(not bench.REALDATA.is_dir(), reason="no ../shared/realdata")
@pytest.mark.parametrize("name", sorted(bench.SETS))
def test_discovery_on_real_sessions(name, tmp_path, capsys):
    rec = bench.run_set(name, tmp_path)
    (tmp_path / "record.json").write_text(json.dumps(rec, indent=1))
    with capsys.disabled():
        print("\n" + bench.table([rec]))
    d = rec["default"]
    assert d["pressure_fy"], d["conclusion"]
    assert not rec["fitted_base"]["pressure_any"], rec["fitted_base"]["conclusion"]
    assert not rec["identified_not_testable"]
    named = {a.split(" ")[1].strip("()") for a in d["accepted"]}
    assert all(d["converged"][p] for p in named)
