"""The real-data judge (bench/realdata.py) runs end to end on one real set (issue 46): import,
the default fit with its report, its error on every loaded sample, the held-out folds and the
verdict, written to the results folder. Quick mode on the smallest set, the default pipeline
only (its verdict is then trivially met: the variants' comparison is the bench's own run).
Skipped where ``../shared/realdata`` is absent."""
from __future__ import annotations

import json
import math

import pytest

from tests.bench_modules import load_bench
from tests.realdata import real_sets, require_realdata, trailer_files

pytestmark = pytest.mark.trials


def test_the_bench_judges_the_smallest_real_set(tmp_path):
    require_realdata()
    folder = min(real_sets(), key=lambda d: sum(p.stat().st_size for p in trailer_files(d)))
    bench = load_bench("realdata")
    code = bench.main(["--sets", str(folder), "--quick", "--variants", "default",
                       "--work", str(tmp_path / "work"), "--out", str(tmp_path / "out")])
    assert code == 0
    doc = json.loads((tmp_path / "out" / "realdata.json").read_text())
    (rec,) = doc["sets"]
    assert rec["import"]["exit"] == 0
    fit = rec["fits"]["default"]
    assert fit["exit"] == 0 and fit["failed"] == []
    assert rec["samples"]["evaluated"] > 0.9 * rec["samples"]["loaded"]
    errors = rec["all_samples"]["default"]
    assert {"Fx", "Fy", "Mz"} <= set(errors)
    assert all(math.isfinite(e["pooled_pct"]) and e["n"] > 0 for e in errors.values())
    held = rec["heldout"]["default"]
    assert held["folds"] and all("heldout" in f for f in held["folds"])
    assert all(math.isfinite(v) for v in held["mean_pct"].values())
    assert set(rec["verdict"]) >= {"Fx", "Fy", "Mz"}
    if len(rec["p_levels_Pa"]) >= 2:
        assert rec["heldout_kind"] == "leave-one-pressure-out"
    text = (tmp_path / "out" / "realdata.md").read_text()
    assert "Held-out error" in text and "Verdict" in text
