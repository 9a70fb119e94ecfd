"""Characteristic tables: SI conversion, validation, and a single CSV as a folder of its own."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from identify.core.errors import InputError
from identify.io.common import Problems
from identify.io.folder import check_folder, load_folder
from identify.io.tables.characteristics import CHARACTERISTICS_COLUMNS, read_characteristics
from tests.measurement_cases import CHARACTERISTICS, EIGEN
from tests.reference_data import THESIS_CSV


def test_converts_to_si_and_adds_p(tmp_path):
    path = tmp_path / "thesis.csv"
    path.write_text(CHARACTERISTICS)
    table = read_characteristics(path)
    assert list(table.columns) == list(CHARACTERISTICS_COLUMNS)
    assert table.unit.tolist() == ["N/m", "N/m", "m", "m"]
    np.testing.assert_allclose(table.value, [251700.0, 145200.0, 0.385, 0.3135], rtol=1e-14)
    assert (table.p_Pa == 250000.0).all() and (table.pi_bar == 2.5).all()
    assert (table.run == "thesis").all() and table.Vx_mps.isna().all()


def test_optional_columns(tmp_path):
    path = tmp_path / "eigen.csv"
    path.write_text(EIGEN.replace("mode", "mode,gamma_deg,Vx_mps").replace(",z", ",z,0,")
                    .replace(",x", ",x,,0.0475"))
    table = read_characteristics(path, run="eig")
    assert table["mode"].tolist() == ["z", "x"]
    assert table.gamma_deg.tolist()[0] == 0.0 and np.isnan(table.gamma_deg[1])
    assert table.Vx_mps[1] == 0.0475 and (table.run == "eig").all()


def test_collects_row_problems(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("quantity,pi_bar,Fz_N,value,unit,mode\n"
                    "CFz,2.5,5000,2e5,N/m,\n"
                    "CFq,2.5,5000,2e5,N/m,\n"
                    "CFy,-2.5,5000,abc,N/m,\n"
                    "sigma_y,2.5,5000,0.4,kN,\n"
                    "f_nat,2.5,0,40,Hz,w\n"
                    "Re,2.5,5000\n")
    problems = Problems()
    assert read_characteristics(path, problems=problems) is None
    assert [str(p) for p in problems.finish()] == [f"{path}:{m}" for m in (
        "3: quantity: unknown quantity 'CFq' (expected one of: CFz, CFx, CFy, CMz, sigma_y, "
        "sigma_x, Re, FxRR, Fy_gamma, Mz_gamma, Mx_gamma, f_nat)",
        "4: pi_bar: must be positive, got -2.5",
        "4: value: not a number: 'abc'",
        "5: unit: unit 'kN' is a force unit, expected a length unit such as 'm' for sigma_y",
        "6: mode: unknown mode 'w' (expected one of: x, y, z, theta, gamma, psi)",
        "7: ragged row: 3 fields, the header has 6")]


def test_header_problems(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("quantity,pi,Fz_N,value,unit\nCFz,2.5,5000,2e5,N/m\n")
    with pytest.raises(InputError, match=r"bad\.csv:1: pi: unknown column"):
        read_characteristics(path)
    path.write_text("")
    with pytest.raises(InputError, match=r"bad\.csv:1: empty file"):
        read_characteristics(path)


def test_single_csv_is_a_folder(tmp_path):
    path = tmp_path / "thesis.csv"
    path.write_text(CHARACTERISTICS)
    found = load_folder(path, nominal_pressure_Pa=250000.0, nominal_load_N=4000.0)
    assert found.manifest.tyre.nominal_load_N == 4000.0
    assert [r.kind for r in found.manifest.runs] == ["characteristics"]
    assert len(found.characteristics) == 4 and found.trailer.empty and found.flatplank.empty
    assert list(found.checksums) == ["thesis.csv"]
    inferred = load_folder(path)
    assert inferred.manifest.tyre.nominal_pressure_Pa == 250000.0
    assert any("nominal load not given" in n for n in inferred.manifest.notes)
    json.dumps(inferred.to_dict())
    assert check_folder(path) == []


def test_thesis_characteristics_load(tmp_path):
    src = THESIS_CSV
    path = shutil.copy(src, tmp_path / "thesis_characteristics.csv")
    found = load_folder(path, nominal_pressure_Pa=2.5e5, nominal_load_N=5000.0)
    table = found.characteristics
    assert len(table) == 75
    assert set(table.quantity) == {"CFz", "CFx", "CFy", "sigma_y", "Re"}
    assert sorted(set(table.pi_bar)) == [1.9, 2.2, 2.5, 2.7, 3.0]
    row = table[(table.quantity == "CFz") & (table.pi_bar == 2.5) & (table.Fz_N == 5000)]
    assert row.value.item() == 251700.0 and row.p_Pa.item() == 250000.0
