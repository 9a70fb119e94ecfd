"""``mfid discover`` from the command line: success and error paths, outputs."""
from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from identify.cli.app import app

runner = CliRunner()

TOML = """[tyre]
id = "cli-tyre"
nominal_pressure_Pa = 250000
nominal_load_N = 5000
unloaded_radius_m = 0.32
source = "simulated"

[[runs]]
id = "table"
file = "characteristics.csv"
kind = "characteristics"
test = "any"
axes = "ISO-W"
"""


def _folder(tmp_path, name, pcfx3, pcfx2=0.0, seed=0):
    """A folder with a CFx table: 5 pressures x 3 loads x 2 starts, 0.5 % noise."""
    rng = np.random.default_rng(seed)
    rows = ["quantity,pi_bar,Fz_N,value,unit"]
    for p in (1.9, 2.2, 2.5, 2.7, 3.0):
        for fz in (2000.0, 4000.0, 6000.0):
            dp, dfz = (p - 2.5) / 2.5, (fz - 5000.0) / 5000.0
            c = 2.2e5 * (1 + 0.25 * dfz + pcfx2 * dfz ** 2) * (1 + pcfx3 * dp)
            for _ in range(2):
                rows.append(f"CFx,{p},{fz},{c * (1 + 0.005 * rng.standard_normal()):.3f},N/m")
    d = tmp_path / name
    d.mkdir()
    (d / "tyre.toml").write_text(TOML)
    (d / "characteristics.csv").write_text("\n".join(rows) + "\n")
    return d


def test_discover_names_the_missing_pressure_term(tmp_path):
    folder = _folder(tmp_path, "hidden", pcfx3=0.2)
    out = tmp_path / "out"
    res = runner.invoke(app, ["discover", str(folder), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "Missing effect: longitudinal tyre stiffness depends on inflation pressure " \
           "(PCFX3 = " in res.stdout
    doc = json.loads((out / "discovery.json").read_text())
    assert doc["schema"] == "mfid.discovery/1"
    assert [a["name"] for a in doc["accepted"]] == ["PCFX3"]
    a = doc["accepted"][0]
    assert a["coefficients"]["PCFX3"] == pytest.approx(0.2, abs=0.02)
    assert a["error_after_pct"] < a["error_before_pct"]
    assert a["heldout_after_pct"] < a["heldout_before_pct"]
    assert doc["tyre"]["id"] == "cli-tyre" and doc["base"]["kind"] == "simplest"
    for name in ("discovery.pdf", "cli-tyre.tir", "fit.json"):
        assert (out / name).stat().st_size > 0
    assert (out / "discovery.pdf").read_bytes()[:4] == b"%PDF"
    tir = (out / "cli-tyre.tir").read_text()
    assert "PCFX3" in tir
    # one line per problem with the noise floor's source (two measurements per condition:
    # the pure error), the held-out scheme, and the same scheme in the conclusion
    assert "CFx: error " in res.stderr and "(replicated conditions, 15 dof)" in res.stderr
    assert "held out: leave one pressure level out" in res.stderr
    assert "held out (leave one pressure level out)" in res.stdout
    assert a["heldout_scheme"] == "leave one pressure level out"
    assert doc["model"]["sources"]["PCFX3"] == "CFx"
    fits = json.loads((out / "fit.json").read_text())
    assert fits["schema"] == "mfid.fit/2" and fits["fits"][0]["relation"] == "CFx"


def test_discover_on_null_data_adds_nothing(tmp_path):
    folder = _folder(tmp_path, "null", pcfx3=0.0, seed=1)
    res = runner.invoke(app, ["discover", str(folder), "--out", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith("No missing effect found")
    doc = json.loads((tmp_path / "o" / "discovery.json").read_text())
    assert doc["accepted"] == [] and doc["steps"][0]["accepted"] is None


def test_base_form_and_default_output_folder(tmp_path, monkeypatch):
    folder = _folder(tmp_path, "quad", pcfx3=0.2, pcfx2=-0.4, seed=2)
    monkeypatch.chdir(tmp_path)
    res = runner.invoke(app, ["discover", str(folder), "--base-form", "CFx/linear_load"])
    assert res.exit_code == 0, res.output
    assert "quadratic load term (PCFX2 = " in res.stdout
    doc = json.loads((tmp_path / "fits" / "cli-tyre" / "discovery" / "discovery.json")
                     .read_text())
    assert doc["base"]["kind"] == "form" and doc["base"]["neutral"] == ["PCFX2"]
    assert [a["name"] for a in doc["accepted"]] == ["PCFX2"]  # PCFX3 is fitted in this base
    assert doc["accepted"][0]["coefficients"]["PCFX2"] == pytest.approx(-0.4, abs=0.05)


@pytest.mark.parametrize("args, message", [
    (["--base-form", "nope"], "unknown base form"),
    (["--alpha", "1.5"], "alpha must lie in (0, 1)"),
    (["--base", "missing.tir", "--base-form", "RR/old"], "not both"),
    (["--only", "sidewall/*"], "nothing to discover"),
    (["--heldout", "sometimes"], "unknown held-out scheme"),
])
def test_discover_user_errors(tmp_path, args, message):
    folder = _folder(tmp_path, "f", pcfx3=0.2)
    res = runner.invoke(app, ["discover", str(folder), "--out", str(tmp_path / "o"), *args])
    assert res.exit_code == 2
    assert message in res.stderr
    assert "Traceback" not in res.output


def test_discover_missing_folder_and_bad_candidates(tmp_path):
    res = runner.invoke(app, ["discover", str(tmp_path / "absent")])
    assert res.exit_code == 2
    bad = tmp_path / "bad.toml"
    bad.write_text("[[candidate]]\nname = 'X'\n")
    folder = _folder(tmp_path, "f", pcfx3=0.2)
    res = runner.invoke(app, ["discover", str(folder), "--candidates", str(bad)])
    assert res.exit_code == 2 and "bad.toml" in res.stderr and "missing" in res.stderr
