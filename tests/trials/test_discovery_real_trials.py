"""Issue 45 acceptance on the real TTC sessions in ``../shared/realdata``
(bench/discovery_real.py; skipped when the folder is absent): on every set with two or more
pressures,

- discovery with the default base names at least one pressure coefficient of Fy;
- with the fitted .tir as base it names no pressure coefficient again;
- every library coefficient the fit identifies beyond 5 standard errors is testable in
  discovery (one view of the data);
- no effect is named from a base fit that did not converge.

Each set is an import, two discoveries and a fit: tens of minutes on a loaded two-core machine.
"""
from __future__ import annotations

import json

import pytest

from tests.bench_modules import load_bench

bench = load_bench("discovery_real")


pytestmark = [pytest.mark.trials,
              pytest.mark.skipif(not bench.REALDATA.is_dir(), reason="no ../shared/realdata")]


@pytest.fixture(scope="module", params=sorted(bench.SETS))
def record(request, tmp_path_factory):
    """One set through import, discovery, fit and discovery on the fitted .tir."""
    work = tmp_path_factory.mktemp(f"discovery-real-{request.param}")
    rec = bench.run_set(request.param, work)
    (work / "record.json").write_text(json.dumps(rec, indent=1))
    print("\n" + bench.table([rec]))
    return rec


def test_what_the_fit_identifies_is_testable(record):
    assert record["fit_identified"], "the case: the fit identifies a library coefficient"
    assert not record["identified_not_testable"], record["default"]["untestable"]


def test_no_effect_named_from_an_unconverged_base(record):
    d = record["default"]
    named = {a.split(" ")[1].strip("()") for a in d["accepted"]}
    assert all(d["converged"][p] for p in named)


def test_default_base_names_a_pressure_coefficient_of_fy(record):
    d = record["default"]
    assert d["converged"]["MF/Fy"], d["conclusion"]
    assert d["pressure_fy"], d["conclusion"]


def test_fitted_base_names_no_pressure_coefficient_again(record):
    f = record["fitted_base"]
    assert not f["pressure_any"], f["conclusion"]
