"""Issue 4, acceptance 1 and 2: extracted characteristics against the simulator's truth.

Two full-grid folders (5 pressures x 3 loads, every test type, 3 start positions) are simulated
once per module: the default artefact level (noise 1 % of each bridge's RMS, start-up
transients, stick-slip, the short relaxation cell), seed 1 as the bundled sample; and a clean
one (no noise, transients or stick-slip; the short relaxation runs stay) with five camber angles
instead of nine (-15, -2, 0, 2 and 15 deg: the smallest angle the camber quantities are compared
at and the largest, where the plank tilts; without noise a cell's error is the method's own, and
the camber runs are two thirds of the samples). Run with ``-s`` to see the worst cell per
quantity.

The tightest checks are set by the noise: the per-cell standard error from the data alone is
~0.3 % for CFx, ~0.2 % for CFy and ~0.5 % for Mx_gamma at |gamma| = 2 deg at the default sample
rates (identify/simulate/grid.py), so the worst of 15 (or 30) cells lands near 2.5 standard
errors, inside the tolerances; ``test_noise_limited_errors_match_their_standard_errors`` checks
every cell against its own standard error. CFx and CFy keep a small systematic part (mean
-0.2 to -0.3 % over the cells, also without noise): the window search cannot tell the last of
the start-up slack take-up (-0.25 % on its own) and the first of the saturation bend (-0.09 %)
from the noise, and they lower the slope slightly (identify/extract/stiffness.py). That is
-1.5 standard errors for a CFy cell: over 200 noise seeds the largest |z| of the 15 CFy cells
passes 4 in 11 % of them (seed 1 here does not). Other tyres: tests/unit/test_extract_tyres.py.
"""
from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest

from identify.extract import extract_folder
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.simulate import FULL, default_tir_path, simulate_folder

#: Issue 4 tolerances (relative) at the default artefact level.
TOLERANCE = {"CFz": 0.01, "CFx": 0.01, "CFy": 0.01, "CMz": 0.03, "sigma_y": 0.02,
             "Re": 0.0005, "Fy_gamma": 0.02, "Mz_gamma": 0.02, "Mx_gamma": 0.02}
CAMBER = ("Fy_gamma", "Mz_gamma", "Mx_gamma")
#: The clean folder's grid: the full grid with five camber angles.
FIVE_CAMBERS = dataclasses.replace(FULL, name="full_5_cambers",
                                   camber_deg=(-15.0, -2.0, 0.0, 2.0, 15.0))


def _simulate(tmp_path_factory, name: str, **artefacts):
    folder = tmp_path_factory.mktemp("extract") / name
    simulate_folder(read_tir(default_tir_path()).params(), folder, seed=1, **artefacts)
    truth = pd.DataFrame(json.loads((folder / "truth.json").read_text())["characteristics"])
    return extract_folder(load_folder(folder)), truth


@pytest.fixture(scope="module")
def default(tmp_path_factory):
    """(Extraction, truth table) of a default-artefact full-grid folder."""
    return _simulate(tmp_path_factory, "default")


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """(Extraction, truth table) without noise, transients and stick-slip."""
    return _simulate(tmp_path_factory, "clean", noise=0.0, transients=False, stick_slip=False,
                     grid=FIVE_CAMBERS)


def compare(extraction, truth: pd.DataFrame) -> pd.DataFrame:
    """Extracted vs true value per cell, ``err`` relative; camber only at |gamma| >= 2 deg."""
    got = extraction.characteristics.copy()
    want = truth.copy()
    for frame in (got, want):
        frame["g"] = frame["gamma_deg"].fillna(0.0) if "gamma_deg" in frame else 0.0
    want = want[want["quantity"].isin(TOLERANCE)]
    out = got.merge(want[["quantity", "pi_bar", "Fz_N", "g", "value"]],
                    on=["quantity", "pi_bar", "Fz_N", "g"], suffixes=("", "_true"),
                    how="right")
    out["err"] = out["value"] / out["value_true"] - 1.0
    return out[~out["quantity"].isin(CAMBER) | (out["g"].abs() >= 2.0)]


def worst_cells(table: pd.DataFrame, title: str) -> dict[str, float]:
    """Print and return the worst relative error per quantity."""
    print(f"\n{title}: worst cell per quantity")
    worst = {}
    for quantity, rows in table.groupby("quantity", sort=False):
        i = rows["err"].abs().idxmax()
        cell = rows.loc[i]
        g = f", gamma {cell['g']:+g} deg" if quantity in CAMBER else ""
        print(f"  {quantity:9s} {100 * cell['err']:+8.4f} %  at {cell['pi_bar']:g} bar, "
              f"{cell['Fz_N']:g} N{g}  ({len(rows)} cells)")
        worst[quantity] = abs(float(cell["err"]))
    return worst


def test_every_cell_is_extracted(default, clean):
    for (extraction, truth), angles in ((default, 8), (clean, 4)):  # |gamma| >= 2 deg
        table = compare(extraction, truth)
        assert table["value"].notna().all(), table[table["value"].isna()]
        counts = table.groupby("quantity").size().to_dict()
        assert counts["CFz"] == counts["CFx"] == counts["CFy"] == counts["sigma_y"] == 15
        assert counts["CMz"] == 30 and counts["Re"] == 15
        assert all(counts[q] == 15 * angles for q in CAMBER)


@pytest.mark.parametrize("quantity", list(TOLERANCE))
def test_acceptance_1_default_artefacts(default, quantity):
    """Issue 4 acceptance 1: each quantity within its tolerance in all 15 cells."""
    table = compare(*default)
    worst = worst_cells(table[table["quantity"] == quantity], "acceptance 1")[quantity]
    assert worst <= TOLERANCE[quantity]


def test_acceptance_1_report(default):
    """Print every quantity's worst cell (always passes; run with -s)."""
    worst = worst_cells(compare(*default), "acceptance 1 (default artefacts, seed 1)")
    assert set(worst) == set(TOLERANCE)


def test_short_relaxation_cell_within_tolerance_and_flagged(default):
    extraction, truth = default
    short = {f["run"] for f in extraction.flags if f["flag"] == "short_run"}
    assert len(short) == 3 and all(r.startswith("relaxation_p190_fz7000") for r in short)
    table = compare(extraction, truth)
    cell = table[(table["quantity"] == "sigma_y") & (table["pi_bar"] == 1.9)
                 & (table["Fz_N"] == 7000.0)]
    print(f"\nshort relaxation cell: sigma_y error {100 * float(cell['err'].iloc[0]):+.3f} %")
    assert abs(float(cell["err"].iloc[0])) <= TOLERANCE["sigma_y"]


def _cell_errors(extraction, quantity: str) -> dict[tuple, float]:
    """Standard error of each cell's mean from the per-run standard errors."""
    per_cell: dict[tuple, list[float]] = {}
    for d in extraction.diagnostics:
        if quantity in ("CFx", "CFy") and d.quantity == quantity:
            per_cell.setdefault((d.pi_bar, d.Fz_N, 0.0), []).append(d.extra["slope_se"])
        elif quantity in CAMBER and d.test == "camber" and "se" in d.extra:
            key = (d.pi_bar, d.Fz_N, d.extra["gamma_deg"])
            per_cell.setdefault(key, []).append(d.extra["se"][quantity])
    return {k: math.sqrt(sum(e * e for e in v)) / len(v) for k, v in per_cell.items()}


@pytest.mark.parametrize("quantity,bound", [("CFx", 0.01), ("CFy", 0.01), ("Mx_gamma", 0.02)])
def test_noise_limited_errors_match_their_standard_errors(default, quantity, bound):
    """The noisiest quantities: every cell within 4 of its own standard errors (a badly biased
    window or build-up fit would leave cells outside), and within the tolerance."""
    extraction, truth = default
    table = compare(extraction, truth)
    table = table[table["quantity"] == quantity]
    se = _cell_errors(extraction, quantity)
    z = [row.err * row.value_true / se[(row.pi_bar, row.Fz_N, row.g)]
         for row in table.itertuples()]
    print(f"\n{quantity}: max |error| / standard error = {np.max(np.abs(z)):.2f}, "
          f"mean error {100 * table['err'].mean():+.3f} %")
    assert np.max(np.abs(z)) <= 4.0
    assert table["err"].abs().max() <= bound
    if quantity == "Mx_gamma":  # above 2 deg the torque outgrows the noise
        assert table[table["g"].abs() >= 5]["err"].abs().max() <= 0.01


def test_acceptance_2_clean(clean):
    """Issue 4 acceptance 2: without noise, transients and stick-slip, all within 0.1 %."""
    extraction, truth = clean
    table = compare(extraction, truth)
    worst = worst_cells(table, "acceptance 2 (no noise, transients, stick-slip)")
    assert max(worst.values()) <= 0.001, worst


def test_clean_folder_raises_only_the_short_run_flags(clean):
    extraction, _ = clean
    assert {f["flag"] for f in extraction.flags} == {"short_run"}


def test_extraction_record_is_json_and_names_windows(default):
    extraction, _ = default
    record = json.loads(json.dumps(extraction.to_dict(), allow_nan=False))
    assert record["schema"] == "mfid.extraction/1"
    assert len(record["runs"]) == len(extraction.diagnostics)
    stiffness = [r for r in record["runs"] if r["quantity"] in ("CFx", "CFy")]
    assert stiffness and all(r["window"][0] < r["window"][1] for r in stiffness)
    assert all(0.99 < r["fit"]["r2"] <= 1.0 for r in stiffness)
    frame = extraction.diagnostics_frame()
    assert {"run", "test", "window", "r2", "rmse", "flags"} <= set(frame.columns)
