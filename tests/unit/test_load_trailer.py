"""Trailer channel files: CSV, HDF5 (layout, exact round trip), units, axes, quick reading."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from identify.core.errors import InputError
from identify.io.common import Problems
from identify.io.hdf5.channel_files import RawRun, write_hdf5
from identify.io.trailer.files import (
    TRAILER_COLUMNS,
    channels_to_tidy,
    read_channels,
    read_trailer,
    write_channels,
)
from tests.measurement_cases import TRAILER_NAMES, trailer_channels, write_csv


def test_csv_quick_read_without_manifest(tmp_path):
    ch = trailer_channels(n=21)
    path = write_csv(tmp_path / "cornering_p250.csv", ch)
    frame = read_trailer(path)
    assert list(frame.columns) == list(TRAILER_COLUMNS)
    assert (frame.run == "cornering_p250").all() and len(frame) == 21
    np.testing.assert_array_equal(frame.Fy, ch["FYW"])  # ISO-W, SI: unchanged
    np.testing.assert_array_equal(frame.t, ch["RUNTIME"])
    pos = frame.alpha > 0
    assert (frame.Fy[pos] < 0).all() and (frame.Mz[pos] > 0).all() and (frame.Fz > 0).all()


def test_units_from_header_and_manifest(tmp_path):
    ch = trailer_channels(n=5)
    ch["SLIPANGL"] = np.degrees(ch["SLIPANGL"])
    ch["LONGVEL"] = ch["LONGVEL"] * 3.6
    ch["FZW"] = ch["FZW"] / 1000.0
    header = [{"SLIPANGL": "SLIPANGL [deg]", "FZW": "FZW [kN]"}.get(k, k) for k in ch]
    path = write_csv(tmp_path / "run.csv", ch, header)
    frame = read_trailer(path, units={"LONGVEL": "km/h", "SLIPANGL": "degree"})
    ref = trailer_channels(n=5)
    np.testing.assert_allclose(frame.alpha, ref["SLIPANGL"], rtol=1e-14, atol=1e-17)
    np.testing.assert_allclose(frame.Vx, 16.7, rtol=1e-14)
    np.testing.assert_allclose(frame.Fz, ref["FZW"], rtol=1e-14)


def test_unit_conflict_and_unknown_unit(tmp_path):
    ch = trailer_channels(n=5)
    header = [{"SLIPANGL": "SLIPANGL [rad]"}.get(k, k) for k in ch]
    path = write_csv(tmp_path / "run.csv", ch, header)
    problems = Problems()
    assert read_channels(path, units={"SLIPANGL": "deg", "INFLPRES": "kpascal",
                                      "NOPE": "s"}, problems=problems) is None
    assert [str(p) for p in problems.finish()] == [
        f"{path}: NOPE: the manifest gives a unit for a channel that is not in the file",
        f"{path}: SLIPANGL: unit conflict: the manifest says 'deg', the file says 'rad'",
        f"{path}: INFLPRES: unknown unit 'kpascal'"]


def test_missing_channel_and_myw_optional(tmp_path):
    ch = trailer_channels(n=5)
    del ch["MYW"]
    frame = read_trailer(write_csv(tmp_path / "a.csv", ch))
    assert frame.My.isna().all()
    del ch["MZW"]
    with pytest.raises(InputError, match=r"a\.csv: MZW: missing required channel"):
        read_trailer(write_csv(tmp_path / "a.csv", ch))


def test_sae_file_is_converted(tmp_path):
    ref = trailer_channels(n=11)
    sae = dict(ref)
    for key in ("FYW", "FZW", "MYW", "MZW", "SLIPANGL"):
        sae[key] = -ref[key]
    frame = read_trailer(write_csv(tmp_path / "sae.csv", sae), axes="SAE")
    for col, key in (("Fy", "FYW"), ("Fz", "FZW"), ("My", "MYW"), ("Mz", "MZW"),
                     ("alpha", "SLIPANGL"), ("Fx", "FX"), ("Mx", "MXW")):
        np.testing.assert_array_equal(frame[col], ref[key])
    # read as ISO-W by mistake: Fz is negative and that is reported
    with pytest.raises(InputError, match="FZW: median Fz is negative"):
        read_trailer(write_csv(tmp_path / "sae.csv", sae))


def test_tydex_c_channels_moved_to_contact_point(tmp_path):
    n = 4
    ch = {k: v for k, v in trailer_channels(n=n).items() if k[0] != "F" and k[0] != "M"}
    ch.update(FXC=np.full(n, 100.0), FYC=np.full(n, -2000.0), FZC=np.full(n, 5000.0),
              MXC=np.full(n, 10.0), MYC=np.full(n, -20.0), MZC=np.full(n, 30.0),
              RLOADED=np.full(n, 0.3))
    frame = read_trailer(write_csv(tmp_path / "c.csv", ch))  # C names -> TYDEX-C inferred
    np.testing.assert_allclose(frame.Mx, 610.0)
    np.testing.assert_allclose(frame.My, 10.0)
    np.testing.assert_allclose(frame.Fy, -2000.0)
    del ch["RLOADED"]
    path = write_csv(tmp_path / "c.csv", ch)
    with pytest.raises(InputError, match="RLOADED: TYDEX-C data need the loaded radius"):
        read_trailer(path)
    frame = read_trailer(path, axes="TYDEX-C", conditions={"loaded_radius_m": 0.3})
    np.testing.assert_allclose(frame.Mx, 610.0)
    with pytest.raises(InputError, match="FXC: a wheel-centre .C-axis. channel, but the run's "
                                         "axes are 'ISO-W'"):
        read_trailer(path, axes="ISO-W")


def test_hdf5_layout_and_exact_round_trip(tmp_path):
    csv = write_csv(tmp_path / "cornering.csv", trailer_channels(n=50))
    runs = read_channels(csv, run="cornering_p250")
    h5 = write_channels(runs, tmp_path / "cornering.h5")
    with h5py.File(h5, "r") as fh:
        assert list(fh) == ["cornering_p250"]
        grp = fh["cornering_p250"]
        assert sorted(grp) == sorted(TRAILER_NAMES)
        assert h5py.h5ds.is_scale(grp["RUNTIME"].id)
        for name in TRAILER_NAMES:
            ds = grp[name]
            assert ds.ndim == 1 and ds.dtype == np.float64
            assert "units" in ds.attrs and "long_name" in ds.attrs
            if name != "RUNTIME":
                assert ds.dims[0][0] == grp["RUNTIME"]  # time attached as the dimension scale
        assert grp["SLIPANGL"].attrs["units"] == "rad"
        assert grp["FYW"].attrs["long_name"] == "lateral force"
    (back,) = read_channels(h5)
    for name in TRAILER_NAMES:
        np.testing.assert_array_equal(back.data[name], runs[0].data[name])
    csv2 = write_channels([back], tmp_path / "again.csv")
    assert csv2.read_bytes() == csv.read_bytes()
    assert read_trailer(h5).equals(read_trailer(csv, run="cornering_p250"))


def test_hdf5_groups_select_runs_and_units_attribute(tmp_path):
    a, b = trailer_channels(n=5, seed=1), trailer_channels(n=7, seed=2)
    b["SLIPANGL"] = np.degrees(b["SLIPANGL"])
    path = write_hdf5(tmp_path / "two.h5", [RawRun("a", a), RawRun("b", b, {"SLIPANGL": "deg"})])
    frame = read_trailer(path)
    assert frame.groupby("run").size().to_dict() == {"a": 5, "b": 7}
    np.testing.assert_allclose(frame[frame.run == "b"].alpha,
                               trailer_channels(n=7, seed=2)["SLIPANGL"], rtol=1e-14)
    assert len(read_trailer(path, run="b")) == 7
    with pytest.raises(InputError, match=r"two\.h5: c: no group 'c' \(groups: a, b\)"):
        read_trailer(path, run="c")
    with pytest.raises(InputError, match="a .csv file holds one run, got 2"):
        write_channels(read_channels(path), tmp_path / "x.csv")


def test_hdf5_bad_values_and_lengths(tmp_path):
    ch = trailer_channels(n=5)
    ch["FYW"] = ch["FYW"].copy()
    ch["FYW"][3] = np.nan
    ch["MZW"] = ch["MZW"][:4]
    path = write_hdf5(tmp_path / "bad.h5", [RawRun("r", ch)])
    problems = Problems()
    assert read_channels(path, problems=problems) is None
    assert [str(p) for p in problems.finish()] == [  # a NaN is a quirk (warning), not here
        f"{path}: r/MZW: 4 samples, but RUNTIME has 5"]


def test_tidy_checks_pressure_and_load(tmp_path):
    (ch,) = read_channels(write_csv(tmp_path / "a.csv", trailer_channels(n=9)))
    problems = Problems()
    assert channels_to_tidy(ch, conditions={"pressure_Pa": 200000.0, "load_N": 7000.0},
                            problems=problems) is None
    text = [str(p) for p in problems.finish()]
    assert text[0] == (f"{tmp_path / 'a.csv'}: INFLPRES: median pressure 250000 Pa is more than "
                       "15% from the declared 200000 Pa")
    assert text[1].startswith(f"{tmp_path / 'a.csv'}: FZW: median load Fz 49")
    assert text[1].endswith("N is more than 15% from the declared 7000 N")
