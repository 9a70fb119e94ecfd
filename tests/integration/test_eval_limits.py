"""``mfid eval`` says what the .tir does not cover: points beyond its limits and coefficient
sections missing altogether are warned of (keys and counts named); a limit pair with its
minimum above its maximum is refused (exit 2, one line, nothing written)."""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.io.tir import read_tir
from identify.io.tir.limits import inverted_limits, missing_sections, points_outside
from tests.model_cases import TIR_DIR

TIR = TIR_DIR / "testA_61.tir"
runner = CliRunner()


def _points(tmp_path: Path, rows: list[tuple]) -> Path:
    path = tmp_path / "points.csv"
    pd.DataFrame(rows, columns=["Fz", "kappa", "alpha", "gamma", "Vx", "p"]).to_csv(
        path, index=False)
    return path


def _run(*args):
    return runner.invoke(app, ["eval", *map(str, args)])


INSIDE = (4000.0, 0.02, 0.05, 0.0, 16.7, 220000.0)


def _edited(tmp_path: Path, replace: dict[str, str] | None = None,
            drop_section: str | None = None) -> Path:
    """testA_61.tir with some lines replaced (``KEY`` -> new line) or a section removed."""
    out, skipping = [], False
    for line in TIR.read_text().splitlines():
        head = line.strip()
        if head.startswith("["):
            skipping = head == f"[{drop_section}]"
        if skipping:
            continue
        key = head.split("=")[0].strip()
        out.append((replace or {}).get(key, line))
    path = tmp_path / "edited.tir"
    path.write_text("\n".join(out) + "\n")
    return path


def test_points_inside_the_limits_give_no_warning(tmp_path):
    result = _run(TIR, "-i", _points(tmp_path, [INSIDE] * 3), "-o", tmp_path / "out.csv")
    assert result.exit_code == 0, result.output
    assert result.stderr == ""


def test_points_beyond_the_limits_are_counted_per_key(tmp_path):
    tir = read_tir(TIR)
    far = [INSIDE, (50000.0, 0.0, 0.0, 0.0, 16.7, 220000.0),
           (4000.0, 0.0, 1.6, 0.0, 16.7, 900000.0), (4000.0, 0.0, 1.6, 0.0, 16.7, 220000.0)]
    result = _run(TIR, "-i", _points(tmp_path, far), "-o", tmp_path / "out.csv")
    assert result.exit_code == 0, result.output
    assert len(pd.read_csv(tmp_path / "out.csv")) == 4  # still evaluated
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"warning: {TIR}: points outside")
    fzmax, alpmax, presmax = (tir.values[k] for k in ("FZMAX", "ALPMAX", "PRESMAX"))
    for text in (f"1 beyond FZMAX = {fzmax:g}", f"2 beyond ALPMAX = {alpmax:g}",
                 f"1 beyond PRESMAX = {presmax:g}", "of 4 points", "clipped"):
        assert text in lines[0], text
    counts = {o.key: o.count for o in points_outside(tir, pd.read_csv(
        tmp_path / "points.csv"))}
    assert counts == {"FZMAX": 1, "ALPMAX": 2, "PRESMAX": 1}


def test_a_missing_coefficient_section_is_named(tmp_path):
    tir_path = _edited(tmp_path, drop_section="LATERAL_COEFFICIENTS")
    assert list(missing_sections(read_tir(tir_path))) == ["LATERAL_COEFFICIENTS"]
    assert missing_sections(read_tir(TIR)) == {}
    result = _run(tir_path, "-i", _points(tmp_path, [INSIDE]), "-o", tmp_path / "out.csv")
    assert result.exit_code == 0, result.output
    line = result.stderr.strip()
    assert line.startswith(f"warning: {tir_path}: [LATERAL_COEFFICIENTS] is missing")
    assert "PCY1" in line and "take their defaults" in line


@pytest.mark.parametrize("low, high", [("FZMIN", "FZMAX"), ("ALPMIN", "ALPMAX"),
                                       ("PRESMIN", "PRESMAX")])
def test_an_inverted_limit_pair_is_refused(tmp_path, low, high):
    tir = read_tir(TIR)
    lo, hi = tir.values[low], tir.values[high]
    tir_path = _edited(tmp_path, {low: f"{low} = {hi * 2 if hi > 0 else hi / 2:g}",
                                  high: f"{high} = {hi:g}"})
    assert inverted_limits(read_tir(tir_path))
    out = tmp_path / "out.csv"
    result = _run(tir_path, "-i", _points(tmp_path, [INSIDE]), "-o", out)
    assert result.exit_code == 2
    assert re.fullmatch(rf"error: {re.escape(str(tir_path))}: {low}: {low} = \S+ > {high} = "
                        rf"\S+: no operating point lies in the range the file declares valid",
                        result.stderr.strip()), result.stderr
    assert not out.exists() and lo < hi
