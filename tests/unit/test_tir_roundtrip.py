""".tir writer: read -> write -> read is exact; layout of the written file; atomic writes."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from identify.core.atomic import atomic_write_csv, atomic_write_text
from identify.core.errors import InputError
from identify.core.version import __version__
from identify.io.tir import format_tir, format_value, read_tir, write_tir
from identify.io.tir.write import DEFAULT_SOURCE, source_text
from identify.model.evaluate import OUTPUT_COLUMNS, evaluate
from identify.model.parameters import PARAMETERS, defaults
from tests.model_cases import random_points
from tests.naive_tir import naive_read
from tests.reference_data import REFERENCE_DIR

_TIRS = sorted(str(p.relative_to(REFERENCE_DIR)) for p in REFERENCE_DIR.rglob("*.tir"))


def _round_trip(src: Path, out: Path):
    first = read_tir(src)
    write_tir(out, first.values, fittyp=first.fittyp, unknown=first.unknown,
              tables=first.tables, comment_lines=[f"source: {src.name}", f"sha256: {first.sha256}"])
    return first, read_tir(out)


def test_reference_data_holds_the_reference_files():
    assert len(_TIRS) == 5


@pytest.mark.parametrize("rel", _TIRS)
def test_reference_files_round_trip_exactly(tmp_path, rel):
    first, second = _round_trip(REFERENCE_DIR / rel, tmp_path / "out.tir")
    assert dict(second.values) == dict(first.values)
    assert dict(second.unknown) == dict(first.unknown)
    assert dict(second.tables) == dict(first.tables)
    assert second.fittyp == first.fittyp and second.warnings == ()
    # only keys that are optional for this FITTYP may be missing from the written file
    always = {p.name for p in PARAMETERS if first.fittyp in p.write_for}
    assert not always & set(second.defaults_used)
    # writing the re-read file again gives the same text
    again = format_tir(second.values, fittyp=second.fittyp, unknown=second.unknown,
                       tables=second.tables,
                       comment_lines=[f"source: {Path(rel).name}", f"sha256: {first.sha256}"])
    assert again == (tmp_path / "out.tir").read_bytes().decode()
    # the simplest line-based reader gets every value the reader got
    naive = naive_read(tmp_path / "out.tir")
    for p in PARAMETERS:
        if p.name in second.values and p.tir_key in naive.get(p.section, {}):
            got = naive[p.section][p.tir_key]
            assert got == second.values[p.name] or (p.is_string and p.section == "UNITS"), p.name
    # and the rewritten file evaluates to identical outputs (bit for bit: same parameters)
    pts = random_points(300, seed=7)
    args = (pts["fz"], pts["kappa"], pts["alpha"], pts["gamma"], pts["vx"], pts["p"])
    a, b = evaluate(first.params(), *args), evaluate(second.params(), *args)
    for name in OUTPUT_COLUMNS:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


def test_non_si_file_with_tables_and_unknown_keys_round_trips(tmp_path):
    src = tmp_path / "in.tir"
    src.write_text("[UNITS]\nLENGTH = 'mm'\nFORCE = 'kN'\nANGLE = 'deg'\n[MODEL]\nFITTYP = 62\n"
                   "FOO = 3\n[DIMENSION]\nUNLOADED_RADIUS = 313.5\n[VERTICAL]\nQ_FZ3 = 'x y'\n"
                   "[SLIP_ANGLE_RANGE]\nALPMAX = 30\n[SHAPE]\n{radial width}\n 1.0 0.0\n"
                   "[MY_SECTION]\nBAR = -1.5e-300\n")
    first, second = _round_trip(src, tmp_path / "out.tir")
    assert dict(second.values) == dict(first.values)
    assert second.values["LENGTH"] == "meter" and second.units["ANGLE"] == "radians"
    assert dict(second.unknown) == {"MODEL.FOO": 3.0, "VERTICAL.Q_FZ3": "x y",
                                    "MY_SECTION.BAR": -1.5e-300}
    assert second.tables == {"SHAPE": ("{radial width}", " 1.0 0.0")}


def test_layout_of_written_file(tmp_path):
    values = defaults()
    values.update({"PKY1": -15.324, "FNOMIN": 4000.0, "QSY4": 4e-05, "TYRESIDE": "RIGHT",
                   "PDX3": 0.1 + 0.2})
    path = write_tir(tmp_path / "a.tir", values, fittyp=61,
                     comment_lines=["fitted from run 7", "second line"])
    raw = path.read_bytes()
    naive_read(path)  # CRLF everywhere, one '=' per data line
    text = raw.decode()
    lines = text.splitlines()
    assert lines[0].startswith("$---") and lines[0].endswith("mdi_header")
    assert lines[1] == "[MDI_HEADER]"
    assert "! : FILE_FORMAT : ASCII" in lines
    assert f"! : TOOL : mfid {__version__} (Magic Formula identification workbench)" in lines
    assert "! : COMMENT : fitted from run 7" in lines and "! : COMMENT : second line" in lines
    assert any("NEVER MODIFY NOMPRES" in line for line in lines if line.startswith("!"))
    headers = [line[1:-1] for line in lines if line.startswith("[")]
    assert headers[0] == "MDI_HEADER" and headers[-1] == "MFID_EXTENSIONS"
    assert len(headers) == 22
    assert not any("=" in line for line in lines if line[:1] in "$!")
    by_key = {line.split("=")[0].strip(): line for line in lines if "=" in line
              and line[0] not in "$!"}
    assert by_key["FITTYP"].split("$")[0].split("=")[1].strip() == "61"
    assert by_key["FNOMIN"].split("$")[0].split("=")[1].strip() == "4000"
    assert by_key["PDX3"].split("$")[0].split("=")[1].strip() == "0.30000000000000004"
    assert by_key["TYRESIDE"].split("$")[0].split("=")[1].strip() == "'RIGHT'"
    assert by_key["LENGTH"].split("$")[0].split("=")[1].strip() == "'meter'"
    assert "[N]" in by_key["FNOMIN"] and "MASS" in by_key and "MASS1" not in by_key
    # aligned columns: '=' and '$' at the same place on every key line of the table
    eq = {line.index("=") for line in by_key.values()}
    assert len(eq) == 1
    # MF 6.2-only keys absent from a 6.1 file with default values; 5.2-only keys absent
    for name in ("Q_FCY2", "Q_CAM1", "ENV_C1", "PTX1", "Q_A1", "LSGKP", "FUNCTION_NAME"):
        assert name not in by_key, name
    for name in ("PPX1", "PPMX1", "PFZ1", "QSY8", "PCFY3", "FREQ_LONG", "BELT_MASS",
                 "ELLIPS_NLENGTH", "PDXP1", "MFID_F_PSI", "MFID_CMZ_FORM"):
        assert name in by_key, name
    # extension keys cannot collide with MF keys; older files with bare names still read
    assert "F_PSI" not in by_key and "CMZ_FORM" not in by_key
    assert any(line.startswith("$") and "ignore" in line for line in lines
               if lines.index("[MFID_EXTENSIONS]") < lines.index(line))


def test_fittyp_62_writes_62_keys_and_61_keeps_non_defaults(tmp_path):
    text62 = format_tir({}, fittyp=62)
    for name in ("Q_FCY2", "Q_CAM3", "Q_FYS1", "ENV_C2"):
        assert f"\n{name} " in text62
    text61 = format_tir({"Q_FCY2": -0.4, "PTX1": 1.5}, fittyp=61)
    assert "\nQ_FCY2 " in text61 and "\nPTX1 " in text61 and "\nQ_CAM3 " not in text61


def test_format_value():
    assert format_value(61) == "61" and format_value(4000.0) == "4000"
    assert format_value(-0.0) == "0" and format_value(1e20) == "1e+20"
    assert float(format_value(1e15)) == 1e15
    assert format_value(123456789012345.0) == "123456789012345"
    assert format_value(2.5e-4) == "0.00025" and format_value(1 / 3) == repr(1 / 3)
    assert format_value("LEFT") == "'LEFT'" and format_value("it's") == '"it\'s"'
    for bad in (math.nan, math.inf, "a'b\"c", "two\nlines"):
        with pytest.raises(ValueError):
            format_value(bad)


def test_writer_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="fittyp"):
        format_tir({}, fittyp=52)
    with pytest.raises(KeyError):
        format_tir({"NOT_A_KEY": 1.0}, fittyp=61)
    with pytest.raises(ValueError):
        format_tir({"PKY1": math.nan}, fittyp=61)
    with pytest.raises(ValueError, match="SECTION.KEY"):
        format_tir({}, fittyp=61, unknown={"NODOT": 1.0})
    with pytest.raises(ValueError):
        write_tir(tmp_path / "x.tir", {"PKY1": math.inf}, fittyp=61)
    assert not (tmp_path / "x.tir").exists() and os.listdir(tmp_path) == []


def test_atomic_write_text_replaces_and_leaves_no_temp(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    os.chmod(target, 0o640)
    atomic_write_text(target, "new\r\nline")
    assert target.read_bytes() == b"new\r\nline"
    assert (target.stat().st_mode & 0o777) == 0o640
    assert sorted(os.listdir(tmp_path)) == ["out.txt"]
    with pytest.raises(InputError, match="cannot write file"):
        atomic_write_text(tmp_path / "missing_dir" / "x.txt", "x")


def test_atomic_write_csv_is_exact(tmp_path):
    df = pd.DataFrame({"a": [0.1 + 0.2, 1e-300, -2.5e17, 1 / 3], "b": ["x", "y", "z", "w"]})
    path = atomic_write_csv(df, tmp_path / "t.csv")
    back = pd.read_csv(path)
    assert back["a"].tolist() == df["a"].tolist() and list(back.columns) == ["a", "b"]
    assert b"\r" not in path.read_bytes()


def test_extension_keys_of_older_files_are_read(tmp_path):
    # mfid before the MFID_ prefix wrote the bare names in [MFID_EXTENSIONS]
    text = format_tir({"F_X": 0.25, "CMZ_FORM": 2.0}, fittyp=61)
    old = text.replace("MFID_F_X ", "F_X      ").replace("MFID_CMZ_FORM ", "CMZ_FORM      ")
    (tmp_path / "old.tir").write_text(old)
    values = read_tir(tmp_path / "old.tir").values
    assert values["F_X"] == 0.25 and values["CMZ_FORM"] == 2.0


def test_key_sources_in_the_comments(tmp_path):
    values = defaults()
    values.update({"PKY1": -18.5, "FNOMIN": 4500.0})
    sources = {"PKY1": source_text("fitted", "MF/Fy0", 0.0123), "FNOMIN": "tyre.toml"}
    path = write_tir(tmp_path / "s.tir", values, fittyp=61, sources=sources)
    lines = path.read_bytes().decode().split("\r\n")
    line = next(x for x in lines if x.startswith("PKY1 "))
    assert line.endswith("; fitted MF/Fy0 +/- 0.0123")
    assert next(x for x in lines if x.startswith("PDY1 ")).endswith(f"; {DEFAULT_SOURCE}")
    assert any(x.startswith("! : COMMENT : key sources") and "1 fitted" in x for x in lines)
    naive_read(path)
    assert read_tir(path).values["PKY1"] == -18.5
