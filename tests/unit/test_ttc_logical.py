"""A MATLAB ``logical`` (true/false) vector in a TTC .mat file is not a measurement (issue 44).

scipy.io reads a v5 logical array as uint8 0/1 and MATLAB v7.3 stores it as uint8 with the
class ``logical``: read as numbers, ``true`` in every camber sample is 1 rad (57 deg), fitted.
Such a vector is left out with a warning naming it, or refuses the file in one line naming the
file and channel when the fit cannot do without that channel.
"""
from __future__ import annotations

import h5py
import numpy as np
import pytest
import scipy.io

from identify.io.common import Problems
from identify.io.trailer.channels import CHANNELS
from identify.io.trailer.files import channels_to_tidy, read_channels
from identify.io.trailer.ttc_rounds import TTC_OPTIONAL
from identify.io.ttc.files import LOGICAL_REFUSED, TTC_CHANNELS, TTC_TO_TYDEX, read_ttc
from tests.ttc_cases import _small_channels, import_refused, small_mat73


def _v5(path, flags: dict[str, np.ndarray], drop=()):
    """A v5 TTC file whose channels ``flags`` are logical arrays (listed in the struct)."""
    ch = {k: v for k, v in _small_channels().items() if k not in drop}
    content = {k: v.reshape(-1, 1) for k, v in ch.items()}
    content.update({k: np.asarray(v, dtype=bool).reshape(-1, 1) for k, v in flags.items()})
    names = list(content)
    content["channel"] = {"name": np.array(names, dtype=object),
                          "units": np.array([TTC_CHANNELS[k].si_unit if k in TTC_CHANNELS
                                             else "none" for k in names], dtype=object)}
    scipy.io.savemat(path, content, format="5")
    return path


def _v73(path, flags: dict[str, np.ndarray]):
    """small_mat73 with the channels ``flags`` replaced or added as MATLAB logical arrays."""
    small_mat73(path)
    with h5py.File(path, "r+") as fh:
        for name, values in flags.items():
            if name in fh:
                del fh[name]
            ds = fh.create_dataset(name, data=np.asarray(values, np.uint8).reshape(1, -1))
            ds.attrs["MATLAB_class"] = np.bytes_("logical")
    return path


def _warnings(path):
    """The channel warnings (channel, detail, action) of a file that reads."""
    found = []
    for ch in read_channels(path):
        assert channels_to_tidy(ch, warnings=found) is not None
    return [(w.channels, w.detail, w.action) for w in found if w.kind == "channel"]


N = _small_channels()["ET"].size
WRITE = {"v5": _v5, "v73": _v73}


@pytest.mark.parametrize("version", list(WRITE))
def test_a_logical_camber_refuses_the_file_in_one_line(tmp_path, version):
    path = WRITE[version](tmp_path / "B1run1.mat", {"IA": np.ones(N)})
    problems = Problems()
    assert read_ttc(path, problems) is None
    assert [str(p) for p in problems.finish()] == [
        f"{path}: IA: a MATLAB logical (true/false) array, not a measurement"]
    assert import_refused([path], tmp_path / "out") == [
        f"error: {path}: IA: a MATLAB logical (true/false) array, not a measurement"]


@pytest.mark.parametrize("version", list(WRITE))
def test_a_logical_vector_beside_the_channels_is_left_out_with_a_warning(tmp_path, version):
    flag = np.arange(N) % 2
    path = WRITE[version](tmp_path / "B1run1.mat", {"TSTC": flag, "VALID": flag})
    run = read_ttc(path, Problems(strict=True))
    assert "TSTC" not in run.data and "VALID" not in run.data and "IA" in run.data
    detail = "a MATLAB logical (true/false) array, not a measurement"
    warned = _warnings(path)
    assert (("TSTC",), detail, "channel left out") in warned
    assert (("VALID",), detail, "channel left out") in warned


def test_a_scalar_logical_is_not_a_channel_and_says_nothing(tmp_path):
    path = _v5(tmp_path / "B1run1.mat", {})
    content = scipy.io.loadmat(path)
    content["isSI"] = np.array([[True]])
    scipy.io.savemat(path, {k: v for k, v in content.items() if not k.startswith("__")})
    assert not [w for w in _warnings(path) if "logical" in w[1]]


def test_a_uint8_channel_of_zeros_and_ones_is_still_a_measurement(tmp_path):
    """Only MATLAB's logical class is refused: an integer channel stays a number."""
    path = tmp_path / "B1run1.mat"
    _v5(path, {})
    content = scipy.io.loadmat(path)
    content["IA"] = np.zeros((N, 1), np.uint8)
    scipy.io.savemat(path, {k: v for k, v in content.items() if not k.startswith("__")})
    run = read_ttc(path, Problems(strict=True))
    assert run.data["IA"].dtype == np.float64 and (run.data["IA"] == 0).all()


def test_the_refused_channels_are_the_ones_the_trailer_loader_requires():
    required = {ttc for ttc, tydex in TTC_TO_TYDEX.items()
                if CHANNELS[tydex][3] and tydex not in TTC_OPTIONAL}
    assert LOGICAL_REFUSED == required
