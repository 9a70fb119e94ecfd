"""Forward model vs MFeval 4.0 sweep grids on three public .tir files (tests/data/reference/mfeval).

MFeval evaluated every row in its own call, which is what our default solver options do
(Re iterated per point). Tolerance 1e-9 relative (|d|/max(1,|ref|)), the issue's acceptance
level. MF 6.2 rho, Rl, Cz are checked against the exact root in ``__Rl_root.csv``: MFeval 4.0's
fminsearch is off the root by up to 4.6e-7 m (and misses it in 27 rows), while our default
solve goes to round-off, so 1e-9 is both attainable and meaningful there.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from tests.reference_data import MFEVAL_DIR

TYRES = ("MagicFormula61_Paramerters", "MagicFormula62_Paramerters", "reference_tire_tvd3")
GRIDS = ("pure_lat", "pure_long", "combined", "pure_lat_mode121")
SCORED = ("Fx", "Fy", "Fz", "Mx", "My", "Mz", "Re", "2a", "2b", "t", "mux", "muy", "Kya", "Kxk",
          "sigmax", "sigmay", "Cx", "Cy", "Mzr", "omega")
TOL = 1e-9


def _relative(a, b):
    return np.abs(a - b) / np.maximum(1.0, np.abs(b))


def _run(tyre, grid):
    P = read_tir(MFEVAL_DIR / f"{tyre}.tir").params()
    df = pd.read_csv(MFEVAL_DIR / f"{tyre}__{grid}.csv")
    mode = 121 if grid.endswith("mode121") else 111
    out = evaluate(P, df.in_Fz, df.in_kappa, df.in_alpha, df.in_gamma, df.in_Vx, p=df.in_p,
                   phit=df.in_phit, mode=mode)
    return df, out


@pytest.mark.parametrize("grid", GRIDS)
@pytest.mark.parametrize("tyre", TYRES)
def test_grid(tyre, grid):
    df, out = _run(tyre, grid)
    columns = SCORED + (() if tyre.startswith("MagicFormula62") else ("rho", "Rl", "Cz"))
    for name in columns:
        ref = df[name].to_numpy(float)
        err = _relative(out[name], ref)
        assert np.array_equal(np.isnan(out[name]), np.isnan(ref)), name
        assert np.nanmax(err) <= TOL, \
            f"{name}: worst {np.nanmax(err):.2e} at row {np.nanargmax(err)}"
    assert len(df) in (192, 558)


@pytest.mark.parametrize("grid", GRIDS)
def test_mf62_loaded_radius_against_exact_root(grid):
    tyre = "MagicFormula62_Paramerters"
    df, out = _run(tyre, grid)
    root = pd.read_csv(MFEVAL_DIR / f"{tyre}__Rl_root.csv")
    root = root[root.grid == grid].sort_values("row")
    assert len(root) == len(df)
    for name in ("Rl", "rho", "Cz"):
        err = _relative(out[name], root[f"{name}_root"].to_numpy(float))
        assert err.max() <= TOL, f"{name}: worst {err.max():.2e}"
