"""The .tir of ``mfid fit`` says no more than the data: its validity limits are the ranges of
the MF stages' points (not widened by the Flatplank relations' loads and cambers), a fitted
coefficient whose 95 % interval holds 0 is marked, and numbers carry FIT_DIGITS significant
digits, with which the written file reproduces the fit.

A small simulated folder fitted with ``--only MF,camber`` (a few seconds): the camber
relations' Flatplank points reach +-10 deg, the MF stages' +-6 deg.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest

from identify.fit.limits import LIMIT_COLUMNS
from identify.fit.run import FitSettings
from identify.io.tir import format_value, read_tir
from identify.io.tir.write import FIT_DIGITS, ZERO_MARK, holds_zero
from identify.model.evaluate import evaluate
from identify.model.modes import TRAILER_MODE
from identify.simulate import default_tir_path, simulate_folder
from identify.workflows.fit import fit_folder


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    root = tmp_path_factory.mktemp("tirout")
    simulate_folder(read_tir(default_tir_path()).params(), root / "m", seed=1, grid="small",
                    tyre_id="m1")
    return fit_folder(root / "m", out_root=root / "fits",
                      settings=FitSettings(only=("MF", "camber")))


def _lines(run) -> dict[str, str]:
    out = {}
    for line in run.tir_path.read_text().splitlines():
        m = re.match(r"([A-Z][A-Z0-9_]*)\s*=\s*(\S+)\s*\$(.*)", line)
        if m:
            out[m.group(1)] = (m.group(2), m.group(3))
    return out


def test_limits_are_the_range_of_the_mf_stages_points(run):
    points = pd.read_csv(run.csv_path)
    mf = points[points["relation"] == "MF"]
    other = points[points["relation"] != "MF"]
    tir = read_tir(run.tir_path).params()
    # the premise: the relations' points reach beyond the MF stages' in camber
    assert other["gamma_deg"].abs().max() > mf["gamma_deg"].abs().max()
    for (lo, hi), (column, factor) in LIMIT_COLUMNS.items():
        v = mf[column].dropna().to_numpy(float)
        if column == "Fz_N":
            v = v[v > 0]
        if v.size < 2 or v.min() == v.max():
            continue
        assert tir[lo] == pytest.approx(v.min() * factor, rel=1e-7), lo
        assert tir[hi] == pytest.approx(v.max() * factor, rel=1e-7), hi
        assert "MF stages" in run.key_sources[lo].detail


def test_numbers_have_fit_digits_and_zero_intervals_are_marked(run):
    lines = _lines(run)
    marked = 0
    for key, src in run.key_sources.items():
        if key not in lines:
            continue
        text, comment = lines[key]
        value = run.tir_values[key]
        if isinstance(value, str):
            continue
        digits = len(re.sub(r"[-+.]|e.*$", "", text.lower()).lstrip("0"))
        assert digits <= FIT_DIGITS, (key, text)
        assert text == format_value(value, FIT_DIGITS)
        zero = src.kind == "fitted" and holds_zero(value, src.stderr)
        assert (ZERO_MARK in comment) == zero, (key, comment)
        marked += zero
    assert marked > 0  # the small grid leaves some coefficients indistinguishable from 0
    header = run.tir_path.read_text()
    assert f"{marked} fitted marked {ZERO_MARK}" in header


def test_the_written_file_reproduces_the_fit(run):
    """The rounded .tir and the fit's own values give the same MF outputs at every MF point,
    to 1e-7 of each output's largest value: 20 times the relative rounding of one
    coefficient at FIT_DIGITS (5e-9)."""
    points = pd.read_csv(run.csv_path)
    mf = points[points["relation"] == "MF"]
    args = (mf["Fz_N"].to_numpy(float), mf["kappa"].to_numpy(float),
            mf["alpha_rad"].to_numpy(float), np.deg2rad(mf["gamma_deg"].to_numpy(float)),
            mf["Vx_mps"].to_numpy(float))
    p = mf["pi_bar"].to_numpy(float) * 1e5
    full = {k: float(v) for k, v in run.tir_values.items() if not isinstance(v, str)}
    written = read_tir(run.tir_path).params()
    a = evaluate(full, *args, p=p, mode=TRAILER_MODE)
    b = evaluate(written, *args, p=p, mode=TRAILER_MODE)
    rounded = 0.0
    for q in sorted(set(mf["quantity"])):
        sel = (mf["quantity"] == q).to_numpy()
        ya, yb = np.asarray(a[q])[sel], np.asarray(b[q])[sel]
        scale = float(np.max(np.abs(ya)))
        assert math.isfinite(scale) and scale > 0
        assert np.max(np.abs(ya - yb)) <= 1e-7 * scale, (q, np.max(np.abs(ya - yb)) / scale)
        rounded = max(rounded, float(np.max(np.abs(ya - yb))))
    assert rounded > 0  # the file holds rounded numbers, not the fit's own
