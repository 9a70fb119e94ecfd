"""Issue 18, acceptance 5: the extraction meets its tolerances on other tyres, not only on the
bundled one (tests/unit/test_extract_accuracy.py).

Folders are simulated at the default artefact level (1 % bridge noise, start-up transients,
stick-slip, the short relaxation cell) from three .tir files: the bundled 225/50 R17 tyre and
the two public MF 6.1 / 6.2 example files of MFeval (tests/data/reference/mfeval). Each folder
carries its own tyre's structural relations (``relations_from_tir``: NOMPRES 2.6 bar, FNOMIN
6752 N and the vertical, longitudinal, lateral and yaw stiffness keys of the example files). Run
with ``-s`` to see the worst cell per tyre and quantity, with its error in its own standard
errors (z).

The default suite checks the two example tyres at one seed each (2 and 3: the bundled test has
seed 1, and the two example files give the same Flatplank data: they differ only in MF 6.2 keys
that no Flatplank quantity reaches) on the full grid with
five camber angles instead of nine (the camber runs are two thirds of the samples); the
``trials`` marker runs 3 tyres x 3 seeds on the full grid.

Every reported standard error is calibrated (over 200 seeds the cell errors divided by them have
a standard deviation of 0.97-1.01 for CFz, CFx, CFy, CMz and sigma_y). CFx and CFy keep a bias
of about -0.23 % (-0.9 and -1.5 of their standard errors): the locked-hub window starts three
slack take-up lengths into the run and ends in the first tenth of the saturation bend; a later
start or earlier end removes it but raises the standard error more than it saves (the worst
cell then passes 1 % more often), see tests/unit/test_extract_accuracy.py.
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from identify.extract import extract_folder
from identify.extract.vertical import cfz_se
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.simulate import FULL, default_tir_path, simulate_folder
from tests.reference_data import MFEVAL_DIR
from tests.unit.test_extract_accuracy import CAMBER, TOLERANCE, compare

TYRES = {"225_50R17": default_tir_path(),
         "MF61_example": MFEVAL_DIR / "MagicFormula61_Paramerters.tir",
         "MF62_example": MFEVAL_DIR / "MagicFormula62_Paramerters.tir"}
#: The full grid with five camber angles (both signs, |gamma| 2 deg where the noise is
#: largest, 15 deg where the plank tilts).
FEWER_CAMBERS = dataclasses.replace(FULL, name="full_5_cambers",
                                    camber_deg=(-15.0, -2.0, 0.0, 2.0, 15.0))


def _cell_se(extraction, truth_rows: pd.DataFrame) -> list[float]:
    """Standard error of each compared cell's mean, from the per-run standard errors [SI]."""
    runs: dict[tuple, list] = {}
    for d in extraction.diagnostics:
        g = float(d.extra.get("gamma_deg", 0.0)) if d.test == "camber" else 0.0
        runs.setdefault((d.test, d.pi_bar, d.Fz_N, g), []).append(d)
    by_p: dict[float, list] = {}
    for d in extraction.diagnostics:
        if d.quantity == "CFz":
            by_p.setdefault(d.pi_bar, []).append(d)
    key = {"CFx": ("longitudinal_stiffness", "slope_se"), "CFy": ("lateral_stiffness", "slope_se"),
           "CMz": ("parking", "slope_se"), "sigma_y": ("relaxation", "sigma_se")}
    out = []
    for r in truth_rows.itertuples():
        if r.quantity == "CFz":
            ds = by_p[r.pi_bar]
            coef = np.mean([[d.extra["c0_N"], d.extra["c1_N_per_m"], d.extra["c2_N_per_m2"]]
                            for d in ds], axis=0)
            cov = sum(np.asarray(d.extra["cov_coef"]) for d in ds) / len(ds) ** 2
            out.append(float(cfz_se(coef, cov, r.Fz_N)))
            continue
        if r.quantity in CAMBER:
            ds = runs.get(("camber", r.pi_bar, r.Fz_N, r.g), [])
            se = [d.extra["se"][r.quantity] for d in ds if "se" in d.extra]
        elif r.quantity in key:
            test, name = key[r.quantity]
            ds = runs.get((test, r.pi_bar, r.Fz_N, 0.0), [])
            se = [d.extra[name] for d in ds if d.quantity == r.quantity and name in d.extra
                  and math.isfinite(d.value)]
        else:  # Re: from noise-free encoders, no standard error
            se = []
        out.append(math.sqrt(sum(e * e for e in se)) / len(se) if se else math.nan)
    return out


def extract_against_truth(tir: Path, folder: Path, seed: int, grid=FULL) -> pd.DataFrame:
    """Simulate ``tir`` into ``folder``, extract, and compare every cell with the truth.

    Returns the :func:`compare` table plus ``se`` (the cell's standard error) and ``z``
    (its error in standard errors).
    """
    simulate_folder(read_tir(tir).params(), folder, seed=seed, grid=grid)
    truth = pd.DataFrame(json.loads((folder / "truth.json").read_text())["characteristics"])
    extraction = extract_folder(load_folder(folder))
    table = compare(extraction, truth).reset_index(drop=True)
    table["se"] = _cell_se(extraction, table)
    table["z"] = (table["value"] - table["value_true"]) / table["se"]
    return table


def worst_by_quantity(table: pd.DataFrame, title: str) -> dict[str, float]:
    """Print the worst cell per quantity (error in % and in standard errors) and return the
    worst relative errors."""
    print(f"\n{title}: worst cell per quantity")
    worst = {}
    for quantity, rows in table.groupby("quantity", sort=False):
        cell = rows.loc[rows["err"].abs().idxmax()]
        g = f", gamma {cell['g']:+g} deg" if quantity in CAMBER else ""
        z = f"z {cell['z']:+5.2f}" if math.isfinite(cell["z"]) else "z   -  "
        print(f"  {quantity:9s} {100 * cell['err']:+10.4g} % (tolerance "
              f"{100 * TOLERANCE[quantity]:g} %)  {z}  at {cell['pi_bar']:g} bar, "
              f"{cell['Fz_N']:g} N{g}  ({len(rows)} cells)")
        worst[quantity] = abs(float(cell["err"]))
    return worst


def check(table: pd.DataFrame) -> None:
    """Every quantity within its tolerance in every cell; CFz and sigma_y (no known bias)
    within 4 of their standard errors."""
    assert table["value"].notna().all(), table[table["value"].isna()]
    over = table[table["err"].abs() > table["quantity"].map(TOLERANCE)]
    assert over.empty, over[["quantity", "pi_bar", "Fz_N", "g", "err", "z"]]
    unbiased = table[table["quantity"].isin(("CFz", "sigma_y"))]
    assert unbiased["z"].abs().max() <= 4.0, unbiased.loc[unbiased["z"].abs().idxmax()]


@pytest.mark.parametrize("tyre,seed", [("MF61_example", 2), ("MF62_example", 3)])
def test_example_tyres_within_tolerance(tmp_path, tyre, seed):
    table = extract_against_truth(TYRES[tyre], tmp_path / tyre, seed, FEWER_CAMBERS)
    worst_by_quantity(table, f"{tyre}, seed {seed}")
    assert set(table["quantity"]) == set(TOLERANCE)
    check(table)
