"""tyre.toml: frozen dataclasses, and every problem collected with its key."""
from __future__ import annotations

import json

import pytest

from identify.core.errors import InputError
from identify.io.common import Problems
from identify.io.manifest import Manifest, RunSpec, read_manifest
from tests.measurement_cases import TOML


def test_reads_the_test_manifest(tmp_path):
    path = tmp_path / "tyre.toml"
    path.write_text(TOML)
    manifest = read_manifest(path)
    assert isinstance(manifest, Manifest)
    assert manifest.tyre.id == "225-50R17-test" and manifest.tyre.nominal_pressure_Pa == 250000.0
    assert isinstance(manifest.tyre.nominal_load_N, float) and manifest.tyre.source == "simulated"
    assert manifest.rig.hub_a_m == 0.08 and manifest.rig.hub_b_m == 0.05
    assert [r.id for r in manifest.runs] == [
        "parking_p250_fz5000_s1", "camber_p250_fz5000_s1_g5", "cornering_p250",
        "cornering_p220", "cornering_p280", "thesis"]
    run = manifest.runs[2]
    assert run == RunSpec("cornering_p250", "trailer/cornering_p250.csv", "trailer", "cornering",
                          "ISO-W", {"SLIPANGL": "deg", "INFLPRES": "kPa"},
                          {"pressure_Pa": 250000.0, "load_N": 5000.0})
    assert manifest.runs[0].conditions["start_position"] == 1
    assert manifest.runs[4].axes == "SAE" and manifest.runs[3].axes == "ISO-W"
    assert manifest.folder == tmp_path
    json.dumps(manifest.to_dict())
    with pytest.raises(TypeError):
        manifest.runs[0].units["x"] = "deg"


BAD = """\
[tyre]
id = 225
nominal_pressure_Pa = "250 kPa"
unloaded_radius_m = -0.3
colour = "black"

[[runs]]
file = "a.csv"
kind = "trailer"
test = "cornering"
axes = "ISO"
units = { SLIPANGL = "furlong" }
conditions = { pressure_Pa = 2.5e5, load_N = true, tread = 3 }

[[runs]]
file = "b.csv"
kind = "flatplanck"

[[runs]]
id = "a"
file = "c.csv"
kind = "flatplank"
test = "sideways"
"""


def test_collects_every_problem(tmp_path):
    path = tmp_path / "tyre.toml"
    path.write_text(BAD)
    problems = Problems()
    assert read_manifest(path, problems) is None
    assert [str(p) for p in problems.finish()] == [f"{path}: {m}" for m in (
        "tyre.id: expected a string, got an integer (225)",
        "tyre.nominal_pressure_Pa: expected a number, got a string ('250 kPa')",
        "tyre.unloaded_radius_m: must be positive, got -0.3",
        "tyre.colour: unknown key (expected one of: id, nominal_pressure_Pa, nominal_load_N, "
        "unloaded_radius_m, source, size, description)",
        "tyre.nominal_load_N: missing required key (number)",
        "runs[0].axes: unknown axis system 'ISO' (expected one of: ISO-W, SAE, TYDEX-C)",
        "runs[0].units.SLIPANGL: unknown unit 'furlong'",
        "runs[0].conditions.load_N: expected a number, got a boolean (True)",
        "runs[0].conditions.tread: unknown key (expected one of: pressure_Pa, load_N, "
        "start_position, gamma_deg, slip_angle_deg, speed_mps, loaded_radius_m)",
        "runs[1].kind: unknown kind 'flatplanck' (expected one of: trailer, flatplank, "
        "characteristics)",
        "runs[2].test: unknown flatplank test 'sideways' (expected one of: vertical, "
        "longitudinal_stiffness, lateral_stiffness, parking, relaxation, free_rolling, camber, "
        "rolling_resistance, eigenfrequency)",
        "rig: missing table [rig] (hub_a_m, hub_b_m): needed for the flatplank run runs[2]")]


def test_strict_raises_first_problem(tmp_path):
    path = tmp_path / "tyre.toml"
    path.write_text(BAD)
    with pytest.raises(InputError, match=r"tyre\.toml: tyre\.id: expected a string"):
        read_manifest(path)


def test_toml_syntax_error_has_a_line(tmp_path):
    path = tmp_path / "tyre.toml"
    path.write_text(TOML.replace('hub_b_m = 0.05', 'hub_b_m = 0.05 0.06'))
    with pytest.raises(InputError) as err:
        read_manifest(path)
    assert err.value.line == 10 and "invalid TOML" in str(err.value)


def test_duplicate_ids_and_no_runs(tmp_path):
    path = tmp_path / "tyre.toml"
    path.write_text(TOML + '\n[[runs]]\nfile = "trailer/cornering_p250.csv"\nkind = "trailer"\n'
                           'test = "cornering"\n')
    with pytest.raises(InputError, match=r"runs\[6\]\.id: duplicate run id 'cornering_p250' "
                                         r"\(also runs\[2\]\)"):
        read_manifest(path)
    path.write_text(TOML.split("[[runs]]")[0])
    with pytest.raises(InputError, match="runs: expected at least one"):
        read_manifest(path)


def test_the_documented_example_is_valid(tmp_path):
    import re
    from pathlib import Path

    doc = Path(__file__).resolve().parents[2] / "docs" / "measurement-folder.md"
    example = re.search(r"```toml\n(.*?)```", doc.read_text(), re.S).group(1)
    (tmp_path / "tyre.toml").write_text(example)
    manifest = read_manifest(tmp_path / "tyre.toml")
    assert len(manifest.runs) == 9 and manifest.runs[3].conditions["speed_mps"] == 0.0475
    assert {r.axes for r in manifest.runs} == {"ISO-W", "SAE", "TYDEX-C"}
