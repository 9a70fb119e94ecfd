"""``mfid eval`` through typer's CliRunner: success paths, engines, and bad input."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.version import __version__
from identify.model.evaluate import OUTPUT_COLUMNS, evaluate
from tests.model_cases import TIR_DIR, params, random_points

runner = CliRunner()


@pytest.fixture()
def points_csv(tmp_path: Path) -> Path:
    pts = random_points(200, seed=3, edge_cases=False)
    frame = pd.DataFrame({"Fz": pts["fz"], "kappa": pts["kappa"], "alpha": pts["alpha"],
                          "gamma": pts["gamma"], "Vx": pts["vx"], "p": pts["p"]})
    path = tmp_path / "points.csv"
    frame.to_csv(path, index=False)
    return path


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.mark.parametrize("fittyp", [61, 62])
@pytest.mark.parametrize("engine", ["numpy", "fused"])
def test_eval_writes_inputs_and_every_output(tmp_path, points_csv, fittyp, engine):
    out = tmp_path / "out.csv"
    result = _run("eval", TIR_DIR / f"testA_{fittyp}.tir", "--input", points_csv, "--output",
                  out, "--mode", 211, "--engine", engine)
    assert result.exit_code == 0, result.output
    assert "wrote" in result.output
    frame = pd.read_csv(out)
    assert list(frame.columns) == ["Fz", "kappa", "alpha", "gamma", "Vx", "p"] + \
        [c for c in OUTPUT_COLUMNS if c != "Fz"]
    pts = pd.read_csv(points_csv)
    ref = evaluate(params(fittyp), pts.Fz, pts.kappa, pts.alpha, pts.gamma, pts.Vx, p=pts.p,
                   mode=211)
    for name in OUTPUT_COLUMNS:
        # CSV keeps 17 significant digits, so the numpy engine round-trips exactly; the fused
        # engine agrees with it to 1e-10 (tests/unit/test_model_fused.py); MF 6.2 secant 1e-6
        tol = 1e-6 if name in ("rho", "Rl", "Cz") else 1e-10
        np.testing.assert_allclose(frame[name], ref[name], rtol=tol, atol=tol, err_msg=name)


def test_eval_keeps_optional_columns_and_uses_omega(tmp_path, points_csv):
    pts = pd.read_csv(points_csv).assign(omega=50.0, phit=0.0, label="x")
    pts.to_csv(points_csv, index=False)
    out = tmp_path / "out.csv"
    assert _run("eval", TIR_DIR / "testA_61.tir", "-i", points_csv, "-o", out).exit_code == 0
    frame = pd.read_csv(out)
    assert (frame["label"] == "x").all()
    np.testing.assert_allclose(frame["omega"], 50.0, rtol=1e-15)


def test_mfeval_call_semantics_flag(tmp_path, points_csv):
    out = tmp_path / "out.csv"
    result = _run("eval", TIR_DIR / "testA_62.tir", "-i", points_csv, "-o", out,
                  "--mfeval-call")
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("args,message", [
    (["--mode", "112"], "--mode: useMode 112: turn slip (units digit 2) is not supported; "
                        "use 111, 121, 211 or 221"),
    (["--mode", "311"], "--mode: useMode 311 is not valid: use 111, 121, 211 or 221"),
    (["--engine", "fused", "--mfeval-call"], "--engine: --mfeval-call needs --engine numpy"),
])
def test_eval_bad_options(tmp_path, points_csv, args, message):
    out = tmp_path / "out.csv"
    result = _run("eval", TIR_DIR / "testA_61.tir", "-i", points_csv, "-o", out, *args)
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {message}"
    assert not out.exists()


@pytest.mark.parametrize("content,message", [
    ("Fz,kappa,alpha,gamma,Vx\n5000,0,0,0,16.7\n",
     "{p}:1: missing column(s) p (found: Fz, kappa, alpha, gamma, Vx)"),
    ("Fz,kappa,alpha,gamma,Vx,p\n5000,0,abc,0,16.7,250000\n",
     "{p}:2: alpha: not a number: 'abc'"),
    ("Fz,kappa,alpha,gamma,Vx,p\n5000,0,0,0,16.7,250000\n5000,0,0,nan,16.7,250000\n",
     "{p}:3: gamma: nan is not allowed"),
    ("Fz,kappa,alpha,gamma,Vx,p\n5000,0,0,0,,250000\n", "{p}:2: Vx: empty cell"),
    ("", "{p}: empty file: expected a header line with columns Fz, kappa, alpha, gamma, Vx, p"),
    ("Fz,kappa,alpha,gamma,Vx,p\n", "{p}:1: no operating points below the header"),
])
def test_eval_bad_points(tmp_path, content, message):
    pts = tmp_path / "points.csv"
    pts.write_text(content)
    out = tmp_path / "out.csv"
    result = _run("eval", TIR_DIR / "testA_61.tir", "-i", pts, "-o", out)
    assert result.exit_code == 2
    assert result.stderr.strip() == "error: " + message.format(p=pts)
    assert "Traceback" not in result.output
    assert not out.exists()


def test_version_and_help():
    result = _run("--version")
    assert result.exit_code == 0 and result.output.strip() == f"mfid {__version__}"
    result = _run("eval", "--help")
    assert result.exit_code == 0 and "--mode" in result.output
