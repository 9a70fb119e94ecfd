"""Malformed .tir files: the exact one-line message from read_tir and from ``mfid eval``.

Each file in tests/data/tir_bad is tests/data/tir_min.tir with one defect. The expected
messages are templates with ``{path}`` for the file path as given.
"""
from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from identify.core.errors import InputError
from identify.io.tir import read_tir

BAD = Path(__file__).resolve().parents[1] / "data" / "tir_bad"
_FITTYP = "(mfid evaluates MF 6.1 = 61 and MF 6.2 = 62)"
_NO_FITTYP = "no FITTYP found: a Magic Formula .tir file needs FITTYP = 61 or 62 in [MODEL]"

EXPECTED = {
    "malformed_number.tir": "{path}:28: PKY1: malformed number '1.2.3'",
    "unsupported_fittyp.tir": "{path}:15: FITTYP: unsupported FITTYP 52 " + _FITTYP,
    "mf52_fittyp.tir": "{path}:15: FITTYP: unsupported FITTYP 6 " + _FITTYP,
    "missing_fittyp.tir": "{path}: " + _NO_FITTYP,
    "only_comments.tir": "{path}: " + _NO_FITTYP,
    "duplicate_key.tir": "{path}:23: FNOMIN: given twice with different values "
                         "(line 22: 4000, line 23: 4500)",
    "unparsable_line.tir": "{path}:23: cannot parse line: 'VERTICAL_STIFFNESS         209651'",
    "key_without_name.tir": "{path}:27: cannot parse line: '= 0.8785'",
    "bad_section_header.tir": "{path}:21: cannot parse line: '[VERTICAL'",
    "key_before_section.tir": "{path}:1: FNOMIN: KEY = VALUE before the first [SECTION] header",
    "string_for_number.tir": "{path}:22: FNOMIN: expected a number, got the string 'abc'",
    "unterminated_string.tir": "{path}:16: TYRESIDE: unterminated string 'LEFT",
    "unknown_unit.tir": "{path}:8: LENGTH: unknown unit 'furlong'",
    "nan_value.tir": "{path}:27: PDY1: not a finite number 'NaN'",
    "inf_value.tir": "{path}:26: PCY1: not a finite number '-Inf'",
    "overflow_number.tir": "{path}:22: FNOMIN: not a finite number '1e999'",
    "empty.tir": "{path}: empty file",
    "blank_lines_only.tir": "{path}: empty file",
    "binary_garbage.tir": "{path}: cannot read file: binary data (NUL bytes), "
                          "not a .tir text file",
    "non_utf8.tir": "{path}:16: TYRESIDE: non-UTF-8 byte 0xE9",
}

_MODEL_READY = all(importlib.util.find_spec(m) is not None
                   for m in ("identify.model.evaluate", "identify.io.tables.points"))
needs_model = pytest.mark.xfail(not _MODEL_READY, reason="model not yet available",
                                strict=False)


def test_every_bad_file_has_an_expected_message():
    assert sorted(p.name for p in BAD.glob("*.tir")) == sorted(EXPECTED)
    assert len(EXPECTED) >= 12


def test_the_base_file_is_valid(data_dir):
    assert read_tir(data_dir / "tir_min.tir").fittyp == 61


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_read_tir_message(name):
    path = BAD / name
    with pytest.raises(InputError) as info:
        read_tir(path)
    message = str(info.value)
    assert message == EXPECTED[name].format(path=path)
    assert "\n" not in message and info.value.exit_code == 2


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(InputError) as info:
        read_tir(tmp_path / "nope.tir")
    assert str(info.value) == f"{tmp_path / 'nope.tir'}: cannot read file: no such file"
    with pytest.raises(InputError) as info:
        read_tir(tmp_path)
    assert str(info.value) == f"{tmp_path}: cannot read file: is a directory"


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0,
                    reason="permissions are not enforced for root")
def test_unreadable_file(tmp_path):
    path = tmp_path / "locked.tir"
    path.write_text("[MODEL]\nFITTYP = 61\n")
    path.chmod(0)
    with pytest.raises(InputError) as info:
        read_tir(path)
    assert str(info.value) == f"{path}: cannot read file: permission denied"


@pytest.fixture
def points_csv(tmp_path) -> Path:
    path = tmp_path / "points.csv"
    path.write_text("Fz,kappa,alpha,gamma,Vx,p\n4000,0,0.05,0,16.7,220000\n"
                    "6000,0.05,-0.02,0.01,16.7,250000\n")
    return path


@needs_model
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_cli_eval_reports_one_line_and_exit_2(tmp_path, points_csv, name):
    from identify.cli.app import app

    bad = BAD / name
    out = tmp_path / "out.csv"
    result = CliRunner().invoke(app, ["eval", str(bad), "--input", str(points_csv),
                                      "--output", str(out)])
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert lines == ["error: " + EXPECTED[name].format(path=str(bad))], result.output
    assert result.exit_code == 2
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert not out.exists()
    assert sorted(os.listdir(tmp_path)) == ["points.csv"]


@needs_model
def test_cli_eval_good_file_writes_output(tmp_path, points_csv, data_dir):
    from identify.cli.app import app

    out = tmp_path / "out.csv"
    result = CliRunner().invoke(app, ["eval", str(data_dir / "tir_min.tir"), "--input",
                                      str(points_csv), "--output", str(out)])
    assert result.exit_code == 0, result.output
    assert out.exists()
    # a minimal file: every coefficient section it leaves out is named (outputs on defaults)
    lines = result.stderr.strip().splitlines()
    assert lines and all(line.startswith("warning: ") and "is missing" in line
                         for line in lines), result.stderr
    assert any("[LONGITUDINAL_COEFFICIENTS] is missing" in line for line in lines)
    assert not any("[LATERAL_COEFFICIENTS]" in line for line in lines)  # it has some
