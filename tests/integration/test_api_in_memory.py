"""The in-memory Python API (issue 43): ``mfid.fit`` writes nothing and returns a run whose
results carry ``lmfit.Parameters``, short reprs, tables and plots; ``run.save`` then
``FitRun.load`` give the same parameters; ``mfid.evaluate`` takes the saved .tir's TirFile."""
from __future__ import annotations

import os
from pathlib import Path

import lmfit
import numpy as np
import pandas as pd
import pytest

import mfid

THESIS = Path(__file__).resolve().parents[2] / "measurements" / "thesis-225-50R17"


def _files(root: Path) -> set[Path]:
    return {Path(d) / f for d, _, fs in os.walk(root) for f in fs}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("cwd")
    before = _files(cwd) | _files(THESIS)
    old = os.getcwd()
    os.chdir(cwd)  # fit_folder's default ./fits would land here: nothing may
    try:
        fitted = mfid.fit(THESIS, only=["CFz"], progress=False)
    finally:
        os.chdir(old)
    assert _files(cwd) | _files(THESIS) == before
    return fitted


def test_fit_writes_nothing_and_returns_parameters(run):
    assert run.fit_dir is None
    assert isinstance(run.results[0].params, lmfit.Parameters)
    result = run.results[0]
    free = [n for n in result.params if result.params[n].vary]
    assert free and set(free) <= set(result.free)
    name = free[0]
    assert result.params[name].value == result.parameters[name]
    assert result.params[name].stderr == pytest.approx(result.stderr[name])


def test_reprs_are_short_and_html_is_a_table(run):
    assert len(repr(run)) <= 2000 and len(repr(run.results[0])) <= 2000
    assert "\n" not in repr(run)
    assert "<table" in run._repr_html_() and "<table" in run.results[0]._repr_html_()


def test_table_and_plot_come_from_memory(run):
    table = run.table()
    assert isinstance(table, pd.DataFrame) and len(table) == sum(len(r.free)
                                                                  for r in run.results)
    fig = run.plot(run.results[0].name)
    assert len(fig.axes) == 2  # points and residuals, one figure


def test_save_then_load_gives_the_same_parameters(run, tmp_path):
    saved = run.save(tmp_path / "fit")
    assert saved.tir_path.is_file() and saved.json_path.is_file()
    again = mfid.FitRun.load(tmp_path / "fit")
    for a, b in zip(run.results, again.results):
        assert a.name == b.name
        for k, v in a.parameters.items():
            assert b.parameters[k] == pytest.approx(v, rel=1e-15, abs=0.0)
    with pytest.raises(mfid.InputError):
        run.save(tmp_path / "fit")  # a fit is there already
    again.plot(again.results[0].name)


def test_evaluate_takes_the_saved_tir_file(run, tmp_path):
    saved = run.save(tmp_path / "fit")
    tir = mfid.read_tir(saved.tir_path)
    out = mfid.evaluate(tir, fz=[3000.0], kappa=[0.0], alpha=[0.02], gamma=[0.0],
                        vx=[16.7], p=[2.5e5], mode=211)
    same = mfid.evaluate(tir.params(), fz=[3000.0], kappa=[0.0], alpha=[0.02], gamma=[0.0],
                         vx=[16.7], p=[2.5e5], mode=211)
    np.testing.assert_array_equal(out["Fy"], same["Fy"])


def test_a_measurement_set_has_a_short_repr_and_fits_in_memory():
    folder = mfid.load_folder(THESIS)
    assert len(repr(folder)) <= 2000 and "thesis-225-50R17" in repr(folder)


def test_the_api_is_listed():
    assert "fit" in dir(mfid) and "FitRun" in dir(mfid) and "evaluate" in dir(mfid)
