"""Reading .tir files: MFeval agreement, robustness, unit conversion, tables, round trip."""
from __future__ import annotations

import json
import math
import pickle
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from identify.io.tir import TirFile, read_tir, write_tir
from identify.model.parameters import PARAMETERS, defaults
from tests.reference_data import GOLDEN_DIR, MFEVAL_DIR, MFEVAL_FILES, mfeval_params


def _write(tmp_path: Path, text: str, name: str = "t.tir", newline: str = "\n") -> Path:
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode("utf-8"))
    return path


# ---------------------------------------------------------------- reference files

@pytest.mark.parametrize("stem", MFEVAL_FILES)
def test_values_equal_mfeval_parse(stem):
    folder = MFEVAL_DIR
    tir = read_tir(folder / f"{stem}.tir")
    expected = mfeval_params(stem)
    assert len(expected) == 284
    for name, want in expected.items():
        got = tir.values[name]
        if isinstance(want, str):
            assert got == want, name
        else:
            assert isinstance(got, float), name
            assert got == pytest.approx(want, rel=1e-15, abs=0.0), name
    assert tir.fittyp == (62 if "62" in stem else 61)
    assert tir.values["FITTYP"] == float(tir.fittyp)


def test_tvd3_defaults_and_unknown():
    tir = read_tir(MFEVAL_DIR / "reference_tire_tvd3.tir")
    used = set(tir.defaults_used)
    # commented out (!GRAVITY, !MC_CONTOUR_A) or absent from the file
    for name in ("GRAVITY", "MC_CONTOUR_A", "MC_CONTOUR_B", "PROPERTY_FILE_FORMAT", "USE_MODE",
                 "HMAX_LOCAL", "Q_CAM", "Q_FCY2", "Q_FYS3", "ENV_C1", "PTX1", "LSGKP",
                 "F_X", "CMZ_FORM"):
        assert name in used, name
    for name in ("FNOMIN", "PKY1", "MASS1", "Q_FZ2", "QDRP1", "LENGTH", "TYRESIDE", "PPMX1"):
        assert name not in used, name
    order = [p.name for p in PARAMETERS]
    assert list(tir.defaults_used) == sorted(tir.defaults_used, key=order.index)
    assert tir.values["GRAVITY"] == -9.81 and tir.values["PROPERTY_FILE_FORMAT"] == "default"
    assert dict(tir.unknown) == {"VERTICAL.Q_FZ3": 0.0, "SCALING_COEFFICIENTS.LMUV": 0.0,
                                 "TURNSLIP_COEFFICIENTS.QDRP2": 0.0}
    assert tir.values["MASS1"] == 9.3 and tir.values["MASS"] == "kg"
    assert len(tir.sha256) == 64 and tir.warnings == ()


@pytest.mark.parametrize("fittyp", [61, 62])
def test_golden_test_a(fittyp):
    folder = GOLDEN_DIR
    tir = read_tir(folder / f"testA_{fittyp}.tir")
    assert tir.fittyp == fittyp
    overrides = json.loads((folder / "overrides.json").read_text())
    for name, value in overrides.items():
        if name == "FITTYP":
            continue
        want = value.strip("'") if isinstance(value, str) else float(value)
        assert tir.values[name] == want, name
    assert tir.unknown == {} and tir.tables == {}


def test_lf_and_crlf_read_identically(tmp_path):
    data = (MFEVAL_DIR / "reference_tire_tvd3.tir").read_bytes()
    assert b"\r\n" in data
    lf = tmp_path / "lf.tir"
    lf.write_bytes(data.replace(b"\r\n", b"\n"))
    cr = tmp_path / "cr.tir"
    cr.write_bytes(data.replace(b"\r\n", b"\r"))
    crlf = read_tir(MFEVAL_DIR / "reference_tire_tvd3.tir")
    for other in (read_tir(lf), read_tir(cr)):
        assert dict(other.values) == dict(crlf.values)
        assert dict(other.unknown) == dict(crlf.unknown)
        assert other.defaults_used == crlf.defaults_used


# ---------------------------------------------------------------- robustness

MESSY = (
    "\ufeff[MDI_HEADER]   \n"
    "FILE_TYPE\t=\t\"tir\"\n"
    "! : COMMENT : a TNO-style comment with 'quotes' and = signs\n"
    "   $ an indented dollar comment\n"
    "\n"
    "[Units]\n"
    "length = 'meter'\n"
    "FORCE\t\t= \"newton\"\t\t$ double quotes\n"
    "ANGLE = 'radian'\n"
    "[MODEL]\n"
    "FITTYP\t = 62\t$ MF 6.2\n"
    "TyreSide = 'RIGHT'\n"
    "ROAD_INCREMENT = \n"
    "ROAD_DIRECTION =    $ empty with a comment\n"
    "PROPERTY_FILE_FORMAT = 'MF$TYRE!'  $ dollar and bang inside quotes\n"
    "[VERTICAL]\n"
    "VERTICAL_STIFFNESS = 5.6519e+005\n"
    "Q_FZ2 = 1.E-3\n"
    "Q_V1 = .5e-4\n"
    "Q_V2 = -2.5E-4 ! bang comment\n"
    "BREFF = +8\n"
    "DREFF = 1.0D-1\n"
    "[LATERAL_COEFFICIENTS]\n"
    "pky1 = -15.324"
)


def test_messy_file(tmp_path):
    tir = read_tir(_write(tmp_path, MESSY))
    v = tir.values
    assert tir.fittyp == 62 and v["FITTYP"] == 62.0
    assert v["FILE_TYPE"] == "tir" and v["FORCE"] == "newton" and v["ANGLE"] == "radian"
    assert v["TYRESIDE"] == "RIGHT" and v["PROPERTY_FILE_FORMAT"] == "MF$TYRE!"
    assert v["VERTICAL_STIFFNESS"] == 565190.0 and v["Q_FZ2"] == 1e-3
    assert v["Q_V1"] == 0.5e-4 and v["Q_V2"] == -2.5e-4 and v["BREFF"] == 8.0
    assert v["DREFF"] == 0.1 and v["PKY1"] == -15.324
    assert v["ROAD_INCREMENT"] == 0.01 and v["ROAD_DIRECTION"] == 1.0  # empty -> default
    assert "ROAD_INCREMENT" in tir.defaults_used and "ROAD_DIRECTION" in tir.defaults_used
    assert tir.units == {"LENGTH": "meter", "FORCE": "newton", "ANGLE": "radian"}
    assert "MASS" in tir.defaults_used and v["MASS"] == "kg"


def test_line_endings_and_missing_final_newline(tmp_path):
    results = [read_tir(_write(tmp_path, MESSY, f"{i}.tir", nl)).values
               for i, nl in enumerate(["\n", "\r\n", "\r"])]
    assert dict(results[0]) == dict(results[1]) == dict(results[2])
    assert results[0]["PKY1"] == -15.324  # last line had no newline


def test_unit_conversion(tmp_path):
    text = ("[UNITS]\nLENGTH = 'mm'\nFORCE = 'kN'\nANGLE = 'deg'\nMASS = 'g'\nTIME = 'ms'\n"
            "[MODEL]\nFITTYP = 61\nLONGVL = 16.7\n"
            "[DIMENSION]\nUNLOADED_RADIUS = 313.5\n"
            "[OPERATING_CONDITIONS]\nINFLPRES = 0.00022\nNOMPRES = 0.00025\n"
            "[INERTIA]\nMASS = 9300\nIXX = 391000000\n"
            "[VERTICAL]\nFNOMIN = 4\nVERTICAL_STIFFNESS = 0.2\nVERTICAL_DAMPING = 0.05\n"
            "Q_FZ2 = 15.4\n"
            "[STRUCTURAL]\nYAW_STIFFNESS = 87.26646259971648\nFREQ_LAT = 0.04\n"
            "[SLIP_ANGLE_RANGE]\nALPMIN = -30\nALPMAX = 30\n"
            "[LATERAL_COEFFICIENTS]\nPKY1 = -15.324\n"
            "[SHAPE]\n{radial width}\n1.0 0.0\n")
    tir = read_tir(_write(tmp_path, text))
    v = tir.values

    def approx(x):
        return pytest.approx(x, rel=1e-14)

    assert v["UNLOADED_RADIUS"] == approx(0.3135)
    assert v["FNOMIN"] == approx(4000.0)
    assert v["VERTICAL_STIFFNESS"] == approx(200000.0)  # kN/mm -> N/m is x 1e6
    assert v["VERTICAL_DAMPING"] == approx(50.0)  # kN ms/mm -> N s/m
    assert v["ALPMAX"] == approx(math.pi / 6) and v["ALPMIN"] == approx(-math.pi / 6)
    assert v["INFLPRES"] == approx(220000.0) and v["NOMPRES"] == approx(250000.0)  # kN/mm^2
    assert v["LONGVL"] == approx(16.7)  # mm/ms = m/s
    assert v["MASS1"] == approx(9.3) and v["IXX"] == approx(0.391)
    assert v["YAW_STIFFNESS"] == approx(5000.0)  # kN mm/deg -> N m/rad
    assert v["FREQ_LAT"] == approx(40.0)  # 1/ms -> Hz
    assert v["PKY1"] == -15.324 and v["Q_FZ2"] == 15.4  # MF coefficients: never converted
    assert v["GRAVITY"] == -9.81  # defaults are SI already
    assert v["LENGTH"] == "meter" and v["FORCE"] == "newton" and v["ANGLE"] == "radians"
    assert tir.units["LENGTH"] == "mm" and tir.units["ANGLE"] == "deg"
    assert tir.tables == {"SHAPE": ("{radial width}", "1.0 0.0")}


def test_explicit_pressure_unit_and_imperial(tmp_path):
    text = ("[UNITS]\nLENGTH = 'inch'\nFORCE = 'lbf'\nPRESSURE = 'psi'\n"
            "[MODEL]\nFITTYP = 62\n[DIMENSION]\nUNLOADED_RADIUS = 12\n"
            "[OPERATING_CONDITIONS]\nINFLPRES = 32\n[VERTICAL]\nFNOMIN = 1000\n")
    tir = read_tir(_write(tmp_path, text))
    assert tir.values["UNLOADED_RADIUS"] == pytest.approx(0.3048, rel=1e-14)
    assert tir.values["INFLPRES"] == pytest.approx(32 * 6894.757293168361, rel=1e-14)
    assert tir.values["FNOMIN"] == pytest.approx(4448.2216152605, rel=1e-14)
    assert tir.units["PRESSURE"] == "psi" and "PRESSURE" not in tir.values
    assert tir.unknown == {}


def test_pressure_derived_from_force_and_length(tmp_path):
    text = "[UNITS]\nLENGTH = 'cm'\nFORCE = 'kgf'\n[MODEL]\nFITTYP = 61\n" \
           "[OPERATING_CONDITIONS]\nINFLPRES = 2.2\n"
    tir = read_tir(_write(tmp_path, text))
    assert tir.values["INFLPRES"] == pytest.approx(2.2 * 9.80665 / 1e-4, rel=1e-14)


def test_tables_unknown_sections_and_keys(tmp_path):
    text = ("[MODEL]\nFITTYP = 61\nMY_SWITCH = 3\n[VERTICAL]\nQ_FZ3 = 'abc'\nQ_FZ4 = 1.5\n"
            "[SHAPE]\n{radial width}\n 1.0    0.0\n\t1.0    0.4\n"
            "[DEFLECTION_LOAD_CURVE]\n{pen  fz}\n0.000 0\n0.010 2200\n"
            "[CUSTOM_TABLE]\n1 2 3\n4 5 6\n"
            "[CUSTOM_KEYS]\nALPHA = 1\nBETA = 'two'\n")
    tir = read_tir(_write(tmp_path, text))
    assert tir.tables == {"SHAPE": ("{radial width}", " 1.0    0.0", "\t1.0    0.4"),
                          "DEFLECTION_LOAD_CURVE": ("{pen  fz}", "0.000 0", "0.010 2200"),
                          "CUSTOM_TABLE": ("1 2 3", "4 5 6")}
    assert tir.unknown == {"MODEL.MY_SWITCH": 3.0, "VERTICAL.Q_FZ3": "abc",
                           "VERTICAL.Q_FZ4": 1.5, "CUSTOM_KEYS.ALPHA": 1.0,
                           "CUSTOM_KEYS.BETA": "two"}


def test_duplicate_with_same_value_is_a_warning(tmp_path):
    text = "[MODEL]\nFITTYP = 61\n[VERTICAL]\nFNOMIN = 4000\nFNOMIN = 4000.0\n"
    tir = read_tir(_write(tmp_path, text))
    assert tir.values["FNOMIN"] == 4000.0
    assert tir.warnings == ("FNOMIN given twice with the same value (lines 4 and 5)",)


def test_mass_in_units_and_inertia_are_different_keys(tmp_path):
    text = "[UNITS]\nMASS = 'kg'\n[MODEL]\nFITTYP = 61\n[INERTIA]\nMASS = 11.5\n"
    tir = read_tir(_write(tmp_path, text))
    assert tir.values["MASS"] == "kg" and tir.values["MASS1"] == 11.5 and tir.warnings == ()


def test_tirfile_api(tmp_path, data_dir):
    tir = read_tir(data_dir / "tir_min.tir")
    params = tir.params()
    assert params["FITTYP"] == 61.0 and params["PKY1"] == -15.324
    assert "TYRESIDE" not in params and all(isinstance(v, float) for v in params.values())
    assert len(params) == sum(not p.is_string for p in PARAMETERS)
    json.dumps(tir.to_dict())
    assert tir.to_dict()["values"]["TYRESIDE"] == "LEFT"
    again = pickle.loads(pickle.dumps(tir))
    assert isinstance(again, TirFile) and dict(again.values) == dict(tir.values)
    with pytest.raises(TypeError):
        tir.values["FNOMIN"] = 1.0  # type: ignore[index]
    with pytest.raises(AttributeError):
        tir.fittyp = 62  # type: ignore[misc]
    assert tir.path == str(data_dir / "tir_min.tir")


# ---------------------------------------------------------------- property: write -> read

# the keys the model divides by must be non-zero and plausible (tested in test_tir_bad.py)
_NUMERIC = [p.name for p in PARAMETERS if not p.is_string and p.name not in
            ("FITTYP", "FNOMIN", "UNLOADED_RADIUS", "NOMPRES", "LONGVL")]
_finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(fittyp=st.sampled_from([61, 62]),
       changes=st.dictionaries(st.sampled_from(_NUMERIC), _finite, min_size=1, max_size=40))
def test_random_values_round_trip_exactly(fittyp, changes):
    values = defaults()
    values.update(changes)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_tir(Path(tmp) / "r.tir", values, fittyp=fittyp)
        back = read_tir(path)
    values["FITTYP"] = float(fittyp)
    assert dict(back.values) == values
    for name, value in changes.items():
        assert math.copysign(1.0, back.values[name]) == math.copysign(1.0, value) or value == 0


def test_unknown_keys_keep_text_that_is_not_a_finite_number(tmp_path):
    text = "[UNITS]\nLENGTH = 'default'\n[MODEL]\nFITTYP = 61\nBIG = 1e999\nWEIRD = nan\n" \
           "EMPTY =\n"
    tir = read_tir(_write(tmp_path, text))
    assert dict(tir.unknown) == {"MODEL.BIG": "1e999", "MODEL.WEIRD": "nan", "MODEL.EMPTY": ""}
    assert tir.values["LENGTH"] == "meter" and tir.units == {"LENGTH": "default"}
    json.dumps(tir.to_dict())
