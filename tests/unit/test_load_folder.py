"""load_folder on the test folder: every run kind and format, SI / ISO-W, checksums."""
from __future__ import annotations

import hashlib
import json
import math

import numpy as np
import pytest

from identify.core.errors import InputError
from identify.io.flatplank import FLATPLANK_COLUMNS
from identify.io.folder import MeasurementSet, check_folder, load_folder
from identify.io.tables.characteristics import CHARACTERISTICS_COLUMNS
from identify.io.trailer.files import TRAILER_COLUMNS
from tests.measurement_cases import trailer_channels, write_good_folder


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return write_good_folder(tmp_path_factory.mktemp("m") / "folder")


@pytest.fixture(scope="module")
def loaded(folder) -> MeasurementSet:
    return load_folder(folder)


def test_tables_and_columns(loaded):
    assert list(loaded.trailer.columns) == list(TRAILER_COLUMNS)
    assert list(loaded.flatplank.columns) == list(FLATPLANK_COLUMNS) + [
        "pressure_Pa", "load_N", "start_position"]
    assert list(loaded.characteristics.columns) == list(CHARACTERISTICS_COLUMNS)
    assert loaded.trailer.groupby("run").size().to_dict() == {
        "cornering_p250": 41, "cornering_p220": 41, "cornering_p280": 41}
    assert set(loaded.flatplank.test) == {"parking", "camber"}
    assert set(loaded.characteristics.run) == {"thesis", "characteristics"}


@pytest.mark.parametrize("run,pressure,seed", [
    ("cornering_p250", 250000.0, 0),   # CSV, ISO-W, SLIPANGL in deg and INFLPRES in kPa
    ("cornering_p220", 220000.0, 3),   # HDF5, ISO-W
    ("cornering_p280", 280000.0, 4),   # TYDEX, SAE, km/h, deg, bar
])
def test_trailer_runs_in_si_and_iso_w(loaded, run, pressure, seed):
    frame = loaded.trailer[loaded.trailer.run == run]
    ref = trailer_channels(pressure=pressure, seed=seed)
    for col, key in (("t", "RUNTIME"), ("Vx", "LONGVEL"), ("alpha", "SLIPANGL"), ("p", "INFLPRES"),
                     ("Fx", "FX"), ("Fy", "FYW"), ("Fz", "FZW"), ("Mx", "MXW"), ("My", "MYW"),
                     ("Mz", "MZW")):
        np.testing.assert_allclose(frame[col], ref[key], rtol=1e-14, atol=1e-15, err_msg=col)
    pos = frame.alpha > 0
    assert (frame.Fy[pos] < 0).all() and (frame.Mz[pos] > 0).all() and (frame.Fz > 0).all()


def test_flatplank_camber_from_plank_in_degrees(loaded):
    camber = loaded.flatplank[loaded.flatplank.test == "camber"]
    np.testing.assert_allclose(camber.gamma, math.radians(5.0), rtol=1e-14)
    np.testing.assert_allclose(camber.Fz, 5000.0, rtol=0.01)
    assert (camber.load_N == 5000.0).all() and (camber.start_position == 1).all()


def test_checksums_cover_every_input(folder, loaded):
    expected = {"tyre.toml", "flatplank/parking_p250_fz5000_s1.csv",
                "flatplank/camber_p250_fz5000_s1_g5.csv", "trailer/cornering_p250.csv",
                "trailer/cornering_p220.h5", "trailer/cornering_p280.tdx", "tables/thesis.csv",
                "characteristics.csv"}
    assert set(loaded.checksums) == expected
    for rel, digest in loaded.checksums.items():
        assert digest == hashlib.sha256((folder / rel).read_bytes()).hexdigest()


def test_summary_and_json(loaded):
    data = json.loads(json.dumps(loaded.to_dict()))
    assert data["rows"] == {"trailer": 123, "flatplank": 62, "characteristics": 6}
    assert data["manifest"]["tyre"]["id"] == "225-50R17-test"
    assert "characteristics.csv is not listed" in data["manifest"]["notes"][0]
    assert loaded.summary().startswith("225-50R17-test: 7 runs")


def test_manifest_path_is_accepted(folder):
    assert len(load_folder(folder / "tyre.toml").trailer) == 123
    assert check_folder(folder) == []


def test_first_problem_raises(folder, tmp_path):
    import shutil
    root = tmp_path / "f"
    shutil.copytree(folder, root)
    (root / "characteristics.csv").write_text("quantity,pi_bar\n")
    with pytest.raises(InputError) as err:
        load_folder(root)
    assert str(err.value) == f"{root}/characteristics.csv:1: Fz_N: missing required column"


def _gzip_copy(folder, root, rel: str) -> str:
    """Copy the folder to ``root`` with ``rel`` gzip-compressed (manifest pointed at it)."""
    import gzip
    import shutil
    shutil.copytree(folder, root)
    data = (root / rel).read_bytes()
    (root / rel).unlink()
    with gzip.GzipFile(root / f"{rel}.gz", "wb", mtime=0) as fh:
        fh.write(data)
    toml = (root / "tyre.toml").read_text()
    assert f'"{rel}"' in toml
    (root / "tyre.toml").write_text(toml.replace(f'"{rel}"', f'"{rel}.gz"'))
    return f"{rel}.gz"


@pytest.mark.parametrize("rel", ["flatplank/parking_p250_fz5000_s1.csv",
                                 "trailer/cornering_p250.csv"])
def test_gzip_channel_files_load_like_plain_ones(folder, loaded, tmp_path, rel):
    _gzip_copy(folder, tmp_path / "f", rel)
    again = load_folder(tmp_path / "f")
    # the same numbers, bit for bit: decompression is lossless and the parser is the same
    for name in ("flatplank", "trailer"):
        a, b = getattr(loaded, name), getattr(again, name)
        assert a.shape == b.shape
        num = a.select_dtypes("number").columns
        np.testing.assert_array_equal(a[num].to_numpy(), b[num].to_numpy())


def test_corrupt_gzip_file_is_one_clear_problem(folder, tmp_path):
    rel = _gzip_copy(folder, tmp_path / "f", "flatplank/parking_p250_fz5000_s1.csv")
    path = tmp_path / "f" / rel
    path.write_bytes(path.read_bytes()[:-40])  # truncated, as an interrupted copy leaves it
    with pytest.raises(InputError) as err:
        load_folder(tmp_path / "f")
    message = str(err.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert "corrupt compressed data" in message or "cannot read file" in message
