"""``mfid import``: a simulated TTC session (.mat and .dat) -> a measurement folder that loads
and passes ``mfid check`` with its warnings; plain trailer CSV with --units/--axes; unusable
files refused in one line; input files never modified; a single trailer file given to
``mfid fit`` says how to import it."""
from __future__ import annotations

import hashlib
import tomllib
from collections import Counter

import numpy as np
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.io.folder import inspect_folder, load_folder
from identify.io.trailer.files import read_trailer
from identify.workflows.import_session import safe_id
from tests.measurement_cases import trailer_channels, write_csv
from tests.ttc_cases import UNUSABLE, decimated, session

runner = CliRunner()


def _hashes(paths):
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in paths}


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    root = tmp_path_factory.mktemp("import")
    s = session(root / "ttc", seed=21)
    before = _hashes(s.files)
    out = root / "folder"
    result = runner.invoke(app, ["import", *map(str, s.files), "--out", str(out)])
    return s, out, result, before


def test_import_writes_a_folder_without_a_hand_written_manifest(imported):
    s, out, result, before = imported
    assert result.exit_code == 0, result.stderr
    assert _hashes(s.files) == before  # the inputs are never modified
    assert sorted(p.name for p in (out / "trailer").iterdir()) == ["SIM1run4.mat",
                                                                  "SIM1run7.mat"]
    for name in ("SIM1run4.mat", "SIM1run7.mat"):  # copied byte for byte
        assert (out / "trailer" / name).read_bytes() == (s.path / name).read_bytes()
    doc = tomllib.loads((out / "tyre.toml").read_text())
    tyre, truth = doc["tyre"], s.truth["tir"]
    assert tyre["id"] == "mfid-sim-225-50-R17"  # the tireid, made a safe file name
    # the middle pressure level: the 250 kPa block, warmed a few kPa above its cold set point
    assert 250000 <= tyre["nominal_pressure_Pa"] <= 1.04 * 250000
    assert tyre["nominal_load_N"] == pytest.approx(truth["FNOMIN"], rel=0.02)
    r_free = truth["UNLOADED_RADIUS"] * truth["Q_RE0"]
    assert tyre["unloaded_radius_m"] == pytest.approx(r_free, rel=0.02)
    runs = {r["id"]: r for r in doc["runs"]}
    assert runs["SIM1run4"]["test"] == "cornering" and runs["SIM1run7"]["test"] == "combined"
    assert all(r["axes"] == "SAE" and r["kind"] == "trailer" for r in runs.values())
    assert runs["SIM1run4"]["units"]["FZ"] == "N" and runs["SIM1run4"]["units"]["V"] == "kph"
    assert doc["provenance"]["sha256"]["SIM1run4.mat"] == before[s.files[0]]
    out_lines = result.stdout.splitlines()
    assert any("SIM1run4.dat: the same data as" in x for x in out_lines)  # imported once
    assert any(x.startswith("  nominal pressure") and "middle of the pressure levels" in x
               for x in out_lines)


def test_imported_folder_loads_and_passes_check_with_counted_warnings(imported):
    s, out, _, _ = imported
    result = runner.invoke(app, ["check", str(out)])
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith(f"{out}: ok with 12 warning(s) (usable data, cleaned "
                                    "while loading); mfid-sim-225-50-R17: 2 runs (2 trailer)")
    scan = inspect_folder(out)
    assert not scan.problems and len(scan.warnings) == 12
    for run in s.truth["runs"]:
        got = {w.kind: w.count for w in scan.warnings if w.run == run["stem"]}
        want = {k: v["count"] for k, v in run["quirks"].items()}
        assert {k: got[k] for k in want} == want
    mset = load_folder(out)
    assert Counter(mset.trailer["run"]) == {
        r["stem"]: r["samples"] - sum(r["quirks"][k]["count"] for k in
                                      ("time-order", "nan", "dropout", "spike"))
        for r in s.truth["runs"]}
    assert mset.dropped_channels() == {}
    assert mset.trailer["Fz"].median() > 0  # ISO-W (the lifted tyre reads about 0)


def test_import_refuses_an_occupied_folder_and_writes_nothing_on_error(imported, tmp_path):
    s, out, _, _ = imported
    result = runner.invoke(app, ["import", str(s.files[0]), "--out", str(out)])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"error: {out}: exists and is not an empty folder (use "
                                     "--overwrite)")
    bad = tmp_path / "B1run1.mat"
    UNUSABLE[0][1](bad)
    target = tmp_path / "new"
    result = runner.invoke(app, ["import", str(s.files[0]), str(bad), "--out", str(target)])
    assert result.exit_code == 2 and not target.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".new")]


@pytest.mark.parametrize("name,make,expected", UNUSABLE, ids=[c[0] for c in UNUSABLE])
def test_unusable_file_exits_2_with_one_line(tmp_path, name, make, expected):
    path = make(tmp_path / "B1run1.mat")
    result = runner.invoke(app, ["import", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = result.stderr.splitlines()
    assert len(lines) == 1
    text = "error: " + expected.format(p=path)
    assert lines[0].startswith(text[:-3]) if text.endswith("...") else lines[0] == text
    assert not (tmp_path / "out").exists()


def test_dat_files_without_id_take_the_out_folders_name(imported, tmp_path):
    """A TTC .dat carries no tireid. Before: exit 2, 'no tyre id ...; give --id', although
    the user had named the folder the session goes into."""
    s = imported[0]
    dats = [f for f in decimated(s, tmp_path / "short", 10) if f.suffix == ".dat"]
    out = tmp_path / "Hoosier R25B 18x6-10"
    result = runner.invoke(app, ["import", *map(str, dats), "--out", str(out)])
    assert result.exit_code == 0, result.stderr
    assert tomllib.loads((out / "tyre.toml").read_text())["tyre"]["id"] == "Hoosier-R25B-18x6-10"
    assert ("  tyre id 'Hoosier-R25B-18x6-10': the --out folder's name (the files carry no "
            "'tireid'; --id sets another)") in result.stdout.splitlines()


def test_plain_csv_with_units_and_axes(tmp_path):
    ch = trailer_channels(n=401)
    ch["RUNTIME"] = np.linspace(0.0, 40.0, 401)
    sae = dict(ch, SLIPANGL=-np.degrees(ch["SLIPANGL"]), FYW=-ch["FYW"], FZW=-ch["FZW"],
               MZW=-ch["MZW"], MYW=-ch["MYW"], INFLPRES=ch["INFLPRES"] / 1000)
    src = write_csv(tmp_path / "corner.csv", sae)
    before = _hashes([src])
    out = tmp_path / "folder"
    result = runner.invoke(app, ["import", str(src), "--out", str(out), "--id", "Test tyre/1",
                                 "--units", "SLIPANGL=deg,INFLPRES=kPa", "--axes", "SAE",
                                 "--nominal-pressure", "250000", "--nominal-load", "5000",
                                 "--unloaded-radius", "0.32"])
    assert result.exit_code == 0, result.stderr
    assert _hashes([src]) == before
    doc = tomllib.loads((out / "tyre.toml").read_text())
    assert doc["tyre"] == {"id": "Test-tyre-1", "nominal_pressure_Pa": 250000.0,
                           "nominal_load_N": 5000.0, "unloaded_radius_m": 0.32,
                           "source": "measured"}
    (run,) = doc["runs"]
    assert run["axes"] == "SAE" and run["test"] == "cornering"
    assert run["units"] == {"SLIPANGL": "deg", "INFLPRES": "kPa"}
    loaded = load_folder(out).trailer
    ref = read_trailer(src, axes="SAE", units={"SLIPANGL": "deg", "INFLPRES": "kPa"})
    np.testing.assert_array_equal(loaded[ref.columns[1:]].to_numpy(),
                                  ref[ref.columns[1:]].to_numpy())
    np.testing.assert_allclose(loaded["alpha"], ch["SLIPANGL"], rtol=1e-12)
    np.testing.assert_allclose(loaded["Fy"], ch["FYW"], rtol=1e-12)


def test_fit_on_a_single_trailer_file_explains_import(imported):
    s, _, _, _ = imported
    for path in (s.files[0], s.files[1]):
        result = runner.invoke(app, ["fit", str(path), "--no-report"])
        assert result.exit_code == 2
        (line,) = result.stderr.splitlines()
        assert line == (f"error: {path}: a single trailer data file, not a measurement "
                        f"folder: import it first with `mfid import {path} --out FOLDER`, "
                        "then fit FOLDER")


def test_safe_id():
    assert safe_id("Hoosier 18.0x6.0-10 R25B") == "Hoosier-18.0x6.0-10-R25B"
    assert safe_id("../a//b c") == "a-b-c"
    assert safe_id("   ") == ""
