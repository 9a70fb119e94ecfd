"""Validity limits from the measured ranges (identify.fit.limits)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from identify.fit.limits import measured_limits, union_limits


def test_limits_are_the_ranges_of_the_fitted_points():
    rows = pd.DataFrame({
        "pi_bar": [1.9, 2.5, 3.0, 2.5, 2.5], "Fz_N": [3000, 7000, 5000, 0.0, np.nan],
        "alpha_rad": [np.nan, np.nan, -0.2, 0.21, 0.0], "kappa": [np.nan] * 5,
        "gamma_deg": [0.0, -4.0, 2.0, np.nan, 0.0]})
    lim = measured_limits(rows)
    assert lim["PRESMIN"] == 1.9e5 and lim["PRESMAX"] == 3.0e5
    assert lim["FZMIN"] == 3000 and lim["FZMAX"] == 7000      # unloaded rows are not a load
    assert lim["ALPMIN"] == -0.2 and lim["ALPMAX"] == 0.21
    assert lim["CAMMIN"] == pytest.approx(math.radians(-4.0), rel=1e-15)
    assert "KPUMIN" not in lim and "KPUMAX" not in lim          # no slip ratio in the data


def test_a_single_level_is_no_range():
    assert measured_limits(pd.DataFrame({"pi_bar": [2.5, 2.5], "Fz_N": [4000, 4000]})) == {}


def test_the_union_of_spans_contains_each():
    trailer = {"FZMIN": 3000.0, "FZMAX": 7000.0, "CAMMIN": -0.14, "CAMMAX": 0.14,
               "ALPMIN": -0.2, "ALPMAX": 0.2}
    flatplank = {"FZMIN": 1000.0, "FZMAX": 6000.0, "CAMMIN": -0.26, "CAMMAX": 0.26,
                 "PRESMIN": 1.9e5, "PRESMAX": 3e5}
    assert union_limits(trailer, flatplank) == {
        "FZMIN": 1000.0, "FZMAX": 7000.0, "CAMMIN": -0.26, "CAMMAX": 0.26,
        "ALPMIN": -0.2, "ALPMAX": 0.2, "PRESMIN": 1.9e5, "PRESMAX": 3e5}
    assert union_limits(trailer, {}) == trailer and union_limits() == {}
    # half a pair is no span
    assert union_limits({"FZMIN": 10.0}, trailer)["FZMIN"] == 3000.0
