"""``mfid vehicle`` and the vehicle file: outputs, key names, bad input, the fit-report hook."""
from __future__ import annotations

import json
import re
import time
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.errors import InputError
from identify.report.vehicle_pages import VEHICLE_DIR, fit_vehicle_pages
from identify.simulate.default_tyre import default_tir_path
from identify.vehicle.analysis import FIGURE_KEYS, VehicleResult, parse_pressures
from identify.vehicle.spec import default_vehicle, default_vehicle_text, read_vehicle

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]
ISSUE_KEYS = ("front_pressure_Pa", "rear_pressure_Pa", "understeer_gradient_deg_per_mps2",
              "axle_cornering_stiffness_front_N_per_rad",
              "axle_cornering_stiffness_rear_N_per_rad", "max_lateral_acceleration_mps2",
              "yaw_rate_gain_per_s", "yaw_natural_frequency_Hz", "yaw_damping_ratio",
              "ride_body_acceleration_rms_mps2", "ride_wheel_load_rms_N")


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def two_settings(tmp_path_factory):
    out = tmp_path_factory.mktemp("vehicle") / "out"
    result = _run("vehicle", default_tir_path(), "--pressures", "2.5/2.5", "--pressures",
                  "2.5/2.1", "--pressures", "1.2/2.5", "--out", out)
    return out, result


def test_vehicle_writes_json_csvs_and_pdf(two_settings):
    out, result = two_settings
    assert result.exit_code == 0, result.output
    for name in ("vehicle.json", "settings.csv", "handling_diagram.csv",
                 "frequency_response.csv", "axle_stiffness_vs_pressure.csv", "vehicle.pdf"):
        assert (out / name).stat().st_size > 100, name
    doc = json.loads((out / "vehicle.json").read_text())
    assert FIGURE_KEYS == ISSUE_KEYS
    assert [s["label"] for s in doc["settings"]] == ["2.50/2.50 bar", "2.50/2.10 bar",
                                                     "1.20/2.50 bar"]
    for s in doc["settings"]:
        for key in ISSUE_KEYS:
            assert isinstance(s[key], float), key
        curve = s["handling_diagram"]
        assert len(curve["lateral_acceleration_mps2"]) == len(curve["alpha_rear_minus_front_deg"])
        assert curve["lateral_acceleration_mps2"][0] == 0.0
    assert doc["settings"][1]["rear_pressure_Pa"] == 210000.0
    assert doc["tyre"]["sha256"] and doc["vehicle"]["sha256"] and doc["mfid_version"]
    assert doc["options"]["seed"] == 0
    settings = pd.read_csv(out / "settings.csv")
    assert list(settings.columns[1:12]) == list(ISSUE_KEYS)
    assert (out / "vehicle.pdf").read_bytes()[:4] == b"%PDF"


def test_outside_the_tir_range_is_said_in_the_json_and_on_the_console(two_settings):
    out, result = two_settings
    doc = json.loads((out / "vehicle.json").read_text())
    low = doc["settings"][2]
    assert low["outside_validity"] is True
    assert any("front pressure 1.20 bar is outside the .tir's 1.50-3.50 bar" in n
               for n in low["validity_notes"])
    assert "warning: 1.20/2.50 bar: front pressure 1.20 bar" in result.output
    assert doc["settings"][0]["outside_validity"] is False


@pytest.mark.parametrize("pressures, message", [
    ("2.5", "not FRONT/REAR"), ("2.5/x", "not FRONT/REAR"), ("25/2.5", "not a tyre pressure"),
    ("2.5/nan", "not a tyre pressure")])
def test_bad_pressures_exit_2_with_one_line(tmp_path, pressures, message):
    result = _run("vehicle", default_tir_path(), "--pressures", pressures, "--out",
                  tmp_path / "o")
    assert result.exit_code == 2
    assert message in result.output and "Traceback" not in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("edit, message", [
    (("mass_kg = 1660.0", "mass_kg = -5.0"), "vehicle.mass_kg: impossible value -5"),
    (("mass_kg = 1660.0", "mass_kg = \"heavy\""), "vehicle.mass_kg: must be a number"),
    (("mass_kg = 1660.0", "mass_kg = 1660.0\nmass_kgs = 3.0"), "vehicle.mass_kgs: unknown key"),
    (("cg_to_front_axle_m = 1.445", "cg_to_front_axle_m = 3.2"), "between the axles"),
    (("spring_N_per_m = 22000.0", "spring_N_per_m = 0"), "quarter_car.spring_N_per_m"),
    (("wheelbase_m = 2.89\n", ""), "missing key(s): wheelbase_m"),
    (("[quarter_car]", "[quartercar]"), "quartercar: unknown table"),
])
def test_bad_vehicle_file_exits_2_naming_file_and_key(tmp_path, edit, message):
    text = default_vehicle_text()
    assert edit[0] in text
    path = tmp_path / "car.toml"
    path.write_text(text.replace(edit[0], edit[1]))
    before = path.read_bytes()
    result = _run("vehicle", default_tir_path(), "--vehicle", path, "--out", tmp_path / "o")
    assert result.exit_code == 2, result.output
    line = " ".join(result.output.split())
    assert message in line and str(path.name) in line
    assert not (tmp_path / "o").exists() and path.read_bytes() == before
    with pytest.raises(InputError):
        read_vehicle(path)


def test_parse_pressures_is_bar_to_pa():
    assert parse_pressures("2.3/2.1") == (230000.0, 210000.0)


def test_default_vehicle_is_the_documented_sedan_and_the_docs_show_the_file():
    spec = default_vehicle()
    v = spec.vehicle
    assert v.mass_kg == 1660.0 and v.a == pytest.approx(v.wheelbase_m / 2)
    doc = (ROOT / "docs" / "vehicle.md").read_text()
    block = re.search(r"```toml\n(.*?)```", doc, re.S).group(1)
    assert block == default_vehicle_text()


def test_fit_report_gets_the_vehicle_pages_from_the_fit_directory(two_settings, tmp_path):
    out, _ = two_settings
    (tmp_path / VEHICLE_DIR).mkdir()
    (tmp_path / VEHICLE_DIR / "vehicle.json").write_text((out / "vehicle.json").read_text())
    pages = fit_vehicle_pages(SimpleNamespace(path=tmp_path))
    assert [t for t, _ in pages] == ["vehicle: handling", "vehicle: figures",
                                     "vehicle: frequency response", "vehicle: ride"]
    assert fit_vehicle_pages(SimpleNamespace(path=tmp_path / "nothing")) == []
    res = VehicleResult.from_dict(json.loads((out / "vehicle.json").read_text()))
    assert len(res.settings) == 3


def test_api_function_is_exported():
    import mfid

    res = mfid.analyse_vehicle(default_tir_path(), pressures=["2.5/2.5"], curve_points=12)
    assert res.settings[0].figures["yaw_rate_gain_per_s"] > 0
    assert mfid.read_vehicle("default") == default_vehicle()


def test_default_sedan_and_seven_settings_take_under_20_s(tmp_path):
    """Issue 47: `mfid vehicle` on the default sedan and its seven settings in under 20 s
    (processor time of this process, so that other work on the machine does not count)."""
    t0 = time.process_time()
    result = _run("vehicle", default_tir_path(), "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert time.process_time() - t0 < 20.0
    assert len(json.loads((tmp_path / "o" / "vehicle.json").read_text())["settings"]) == 7


def test_fit_with_a_bad_vehicle_file_stops_before_fitting(tmp_path):
    bad = tmp_path / "car.toml"
    bad.write_text(default_vehicle_text().replace("mass_kg = 1660.0", "mass_kg = 0.0"))
    result = _run("fit", ROOT / "measurements" / "thesis-225-50R17", "--out", tmp_path / "fits",
                  "--reports", tmp_path / "reports", "--vehicle", bad)
    assert result.exit_code == 2
    assert "vehicle.mass_kg: impossible value 0" in " ".join(result.output.split())
    assert not (tmp_path / "fits").exists() and not (tmp_path / "reports").exists()


def test_a_tyre_that_pushes_the_wrong_way_is_refused(tmp_path):
    text = Path(default_tir_path()).read_text()
    assert "PKY1                      = -29.8592" in text
    bad = tmp_path / "wrong_sign.tir"
    bad.write_text(text.replace("PKY1                      = -29.8592",
                                "PKY1                      = 29.8592"))
    result = _run("vehicle", bad, "--pressures", "2.5/2.5", "--out", tmp_path / "o")
    assert result.exit_code == 2
    assert "cornering stiffness at the vehicle's static wheel loads is not positive" in \
        " ".join(result.output.split())
    assert not (tmp_path / "o").exists()
