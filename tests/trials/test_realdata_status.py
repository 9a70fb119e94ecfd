"""On every real TTC set the statuses are honest and no MF coefficient is reported at an
arbitrary bound (issue 46, items 3 and 4). Minutes per set: a trial, skipped where
``../shared/realdata`` is absent."""
from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.fit.bounds import ARBITRARY, bound_kinds, side_at
from identify.fit.status import MAX_OK_ERROR_PCT, OK, STATUSES
from tests.realdata import SETS, trailer_files

pytestmark = pytest.mark.trials


@pytest.mark.parametrize("folder", SETS, ids=lambda d: getattr(d, "name", "absent"))
def test_real_set_statuses_and_bounds(tmp_path, folder):
    runner = CliRunner()
    result = runner.invoke(app, ["import", *map(str, trailer_files(folder)), "--out",
                                 str(tmp_path / "set")])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["fit", str(tmp_path / "set"), "--out", str(tmp_path / "fits"),
                                 "--no-report"])
    assert result.exit_code in (0, 1), result.output  # 1: a stage failed, said so
    (doc_path,) = (tmp_path / "fits").glob("*/fit.json")
    doc = json.loads(doc_path.read_text())
    for f in doc["fits"]:
        name = f"{f['relation']}/{f['form']}"
        assert f["fit_status"] in STATUSES, name
        if f["fit_status"] == OK:
            assert f["error_total_pct"] <= MAX_OK_ERROR_PCT, name
        if f["relation"] != "MF":
            continue
        for n in f["at_bound"]:
            v = f["parameters"][n]
            lo, hi = f["bounds"][n]
            lo, hi = -math.inf if lo is None else lo, math.inf if hi is None else hi
            kind = bound_kinds(n, v)[0 if side_at(v, lo, hi) == "lower" else 1]
            assert kind != ARBITRARY, f"{name}: {n} = {v} at an arbitrary bound"
