"""TTC sessions saved as MATLAB v7.3 (HDF5 inside) read as their v5 twins do.

MATLAB writes v7.3 with ``save -v7.3`` and for any variable over 2 GB; scipy.io refuses it.
identify.io.ttc.mat73 reads MATLAB's HDF5 layout (transposed arrays, char as uint16, cells as
object references, structs as groups). The generator writes the same session both ways
(``simulate_ttc(mat_version="7.3")``): every channel, unit and string must come out equal, and
the imported folders must hold the same trailer table.
"""
from __future__ import annotations

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.io.common import Problems
from identify.io.folder import load_folder
from identify.io.ttc.files import read_ttc
from identify.io.ttc.mat73 import is_mat73_header, read_mat73
from tests.ttc_cases import import_refused, session, small_mat73

runner = CliRunner()


@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    root = tmp_path_factory.mktemp("mat73")
    return (session(root / "v5", seed=5, cornering_only=True),
            session(root / "v73", seed=5, cornering_only=True, mat_version="7.3"), root)


def test_v73_session_reads_as_its_v5_twin(twins):
    v5, v73, _ = twins
    f5, f73 = (next(f for f in s.files if f.suffix == ".mat") for s in (v5, v73))
    head = f73.read_bytes()[:128]
    assert is_mat73_header(head) and not is_mat73_header(f5.read_bytes()[:128])
    a, b = (read_ttc(f, Problems(strict=True)) for f in (f5, f73))
    assert list(a.data) == list(b.data)  # the channel struct's order, not HDF5's name order
    for name in a.data:
        np.testing.assert_array_equal(a.data[name], b.data[name], err_msg=name)
    assert dict(a.units) == dict(b.units)
    assert {k: v for k, v in a.attrs.items() if k != "format"} == \
        {k: v for k, v in b.attrs.items() if k != "format"}
    assert (a.attrs["format"], b.attrs["format"]) == ("ttc-mat", "ttc-mat73")


def test_v73_session_imports_to_the_same_trailer_table(twins):
    v5, v73, root = twins
    tables = []
    for s, name in ((v5, "f5"), (v73, "f73")):
        mats = [str(f) for f in s.files if f.suffix == ".mat"]
        result = runner.invoke(app, ["import", *mats, "--out", str(root / name)])
        assert result.exit_code == 0, result.output
        tables.append(load_folder(root / name).trailer)
    assert tables[0].shape == tables[1].shape and len(tables[0]) > 50_000
    for c in tables[0].columns:
        left, right = tables[0][c].to_numpy(), tables[1][c].to_numpy()
        if left.dtype.kind == "f":
            np.testing.assert_array_equal(left, right, err_msg=c)
        else:
            assert (left == right).all(), c


def test_integer_channels_empty_strings_and_row_vectors(tmp_path):
    """What MATLAB also writes: an int32 channel (RUN), an empty char (a blank testid), a 1 x N
    row vector (HDF5 shape (N, 1))."""
    path = small_mat73(tmp_path / "B1run1.mat")
    with h5py.File(path, "r+") as fh:
        n = fh["ET"].shape[1]
        ds = fh.create_dataset("RUN", data=np.full((1, n), 3, np.int32))
        ds.attrs["MATLAB_class"] = np.bytes_("int32")
        ds = fh.create_dataset("testid", data=np.array([1, 0], np.uint64))
        ds.attrs["MATLAB_class"] = np.bytes_("char")
        ds.attrs["MATLAB_empty"] = np.uint8(1)
        sa = fh["SA"][()]
        del fh["SA"]
        ds = fh.create_dataset("SA", data=sa.T)
        ds.attrs["MATLAB_class"] = np.bytes_("double")
    mat = read_mat73(path)
    assert mat["RUN"].shape == (n,) and mat["RUN"].dtype == np.int32 and mat["testid"] == ""
    assert mat["tireid"] == "small" and mat["channel"]["units"][0] == "s"
    np.testing.assert_array_equal(mat["SA"], np.sin(np.arange(n) / 100.0))
    run = read_ttc(path, Problems(strict=True))
    assert run.data["RUN"].dtype == np.float64 and (run.data["RUN"] == 3).all()


def test_a_variable_of_a_class_a_ttc_file_does_not_hold_is_left_out(tmp_path):
    """An extra variable MATLAB saved beside the channels (a function handle) is left out, as
    scipy.io's v5 reading leaves it: the file imports."""
    path = small_mat73(tmp_path / "B1run1.mat")
    with h5py.File(path, "r+") as fh:
        ds = fh.create_dataset("handle", data=np.zeros((1, 1)))
        ds.attrs["MATLAB_class"] = np.bytes_("function_handle")
    mat = read_mat73(path)
    assert "handle" not in mat and "FZ" in mat
    assert read_ttc(path, Problems(strict=True)) is not None


def test_a_channel_of_a_class_a_ttc_file_does_not_hold_is_one_line(tmp_path):
    path = small_mat73(tmp_path / "B1run1.mat")
    with h5py.File(path, "r+") as fh:
        del fh["FZ"]
        ds = fh.create_dataset("fz", data=np.zeros((1, 1)))
        ds.attrs["MATLAB_class"] = np.bytes_("function_handle")
    assert import_refused([path], tmp_path / "out") == [
        f"error: {path}: MATLAB v7.3 .mat file: fz: MATLAB class 'function_handle' is not "
        "read"]


def test_a_member_name_that_is_not_utf8_is_read_as_text(tmp_path):
    """A flipped byte in a name (found by the hypothesis trials: h5py then gives the name as
    bytes, and the reader raised TypeError) is a name like any other."""
    path = small_mat73(tmp_path / "B1run1.mat")
    with h5py.File(path, "r+") as fh:
        ds = fh.create_dataset(b"F\xffX", data=np.zeros((1, fh["ET"].shape[1])))
        ds.attrs["MATLAB_class"] = np.bytes_("double")
    assert "F\ufffdX" in read_mat73(path)
    problems = Problems()
    read_ttc(path, problems)
    assert all("\n" not in str(p) for p in problems.finish())
