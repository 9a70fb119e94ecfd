"""TYDEX .tdx reader and writer: exact round trip, detection, factors/offsets, bad files."""
from __future__ import annotations

import numpy as np
import pytest

from identify.core.errors import InputError
from identify.io.common import Problems
from identify.io.trailer.files import read_channels, read_trailer
from identify.io.tydex import TydexChannel, TydexEntry, TydexFile, is_tydex, read_tydex, write_tydex
from tests.measurement_cases import trailer_channels, write_csv

TEXT = """\
! a comment before the header is allowed
**HEADER
RELEASE   Release of TYDEX-Format       -         1.3
MEASID    Measurement id                -         cornering 1
**COMMENTS
Flat-trac run, tyre 225/50 R17
**CONSTANTS
INFLPRES  Inflation pressure            kPa       250
NOMLOAD   Nominal load                  N         5000
**MEASURCHANNELS
! name    description                   unit      factor offsets
RUNTIME   Running time                  s         1         0         0
SLIPANGL  Slip angle                    deg       0.1       0         0
FYW       Lateral force W               kN        1         1         -1000
**MEASURDATA
0.0 -50 -4.0
0.5 0 0.0
1.0 50 4.0
**END
"""


def _random_file(n: int = 200) -> TydexFile:
    rng = np.random.default_rng(11)
    data = rng.normal(size=(n, 4)) * np.array([1.0, 1e-7, 1e5, 1e300])
    data[0] = [5e-324, -0.0, 1 / 3, 2.0 ** 60]
    channels = (TydexChannel("RUNTIME", "Running time", "s"),
                TydexChannel("SLIPANGL", "Slip angle with a long description text", "rad"),
                TydexChannel("FYW", "Lateral force W", "N"), TydexChannel("X", "big", ""))
    return TydexFile((TydexEntry("MEASID", "Measurement id", "", "run 7"),),
                     ("first comment", "second comment"),
                     (TydexEntry("NOMPRES", "Nominal pressure", "Pa", "250000"),), channels, data)


def test_round_trip_is_exact(tmp_path):
    tdx = _random_file()
    path = write_tydex(tmp_path / "a.tdx", tdx)
    back = read_tydex(path)
    assert np.array_equal(back.data, tdx.data)
    assert np.signbit(back.data[0, 1])  # -0.0 survives
    long = tdx.channels[1]
    assert back.channels[1].description == long.description[:29]  # fixed width: 30 with a space
    assert back.channels[::2] == tdx.channels[::2] and back.channels[3] == tdx.channels[3]
    assert back.header == tdx.header and back.constants == tdx.constants
    assert back.comments == tdx.comments
    write_tydex(tmp_path / "b.tdx", back)
    assert (tmp_path / "b.tdx").read_bytes() == path.read_bytes()


def test_fixed_width_lines(tmp_path):
    path = write_tydex(tmp_path / "a.tdx", _random_file(2))
    lines = path.read_text().splitlines()
    line = next(x for x in lines if x.startswith("SLIPANGL"))
    assert line[10:40].rstrip() == "Slip angle with a long descri"  # 29 characters + space
    assert line[40:50].rstrip() == "rad" and line[50:].split() == ["1", "0", "0"]


def test_reads_factor_offsets_constants_and_comments(tmp_path):
    path = tmp_path / "run.tdx"
    path.write_text(TEXT)
    tdx = read_tydex(path)
    assert [c.name for c in tdx.channels] == ["RUNTIME", "SLIPANGL", "FYW"]
    assert tdx.channels[2] == TydexChannel("FYW", "Lateral force W", "kN", 1.0, 1.0, -1000.0)
    np.testing.assert_allclose(tdx.column("SLIPANGL"), [-5.0, 0.0, 5.0])
    # (raw + offset1) * factor + offset2 = (-4 + 1) * 1 - 1000
    np.testing.assert_allclose(tdx.column("FYW"), [-1003.0, -999.0, -995.0])
    assert tdx.header[1] == TydexEntry("MEASID", "Measurement id", "-", "cornering 1")
    assert tdx.comments == ("Flat-trac run, tyre 225/50 R17",)
    assert tdx.data_line == 16
    # to SI through the trailer channel reader; the constant stands in for INFLPRES
    (ch,) = read_channels(path)
    np.testing.assert_allclose(ch.data["SLIPANGL"], np.radians([-5.0, 0.0, 5.0]), rtol=1e-15)
    np.testing.assert_allclose(ch.data["FYW"], [-1003e3, -999e3, -995e3])
    np.testing.assert_allclose(ch.data["INFLPRES"], 250000.0)
    assert ch.units["FYW"] == "N" and ch.run == "cornering 1"  # MEASID


def test_detected_by_header_not_extension(tmp_path):
    tdx_named_txt = tmp_path / "data.txt"
    tdx_named_txt.write_text(TEXT)
    assert is_tydex(tdx_named_txt)
    csv_named_tdx = write_csv(tmp_path / "sweep.tdx", trailer_channels(n=5))
    assert not is_tydex(csv_named_tdx)
    frame = read_trailer(csv_named_tdx)
    assert len(frame) == 5
    assert read_channels(tdx_named_txt)[0].data["FYW"].size == 3


@pytest.mark.parametrize("mutate,message", [
    (lambda t: t.replace("0.5 0 0.0", "0.5 0"), ":17: ragged row: 2 values, 3 channels"),
    (lambda t: t.replace("0.5 0 0.0", "0.5 x 0.0"), ":17: SLIPANGL: not a number: 'x'"),
    (lambda t: t.replace("0.5 0 0.0", "0.5 nan 0.0"), ":17: SLIPANGL: nan is not allowed"),
    (lambda t: t.replace("**END\n", ""), ": no **END line after the data"),
    (lambda t: t.replace("**MEASURDATA", "**DATA"), ": unknown section '**DATA'"),
    (lambda t: t.replace("0.1       0", "zero      0"),
     ":13: SLIPANGL: factor/offsets are not numbers: 'zero      0         0'"),
    (lambda t: t.replace("**HEADER", "HEADER"), ":2: text before the **HEADER line"),
])
def test_bad_files(tmp_path, mutate, message):
    path = tmp_path / "bad.tdx"
    path.write_text(mutate(TEXT))
    with pytest.raises(InputError) as err:
        read_tydex(path)
    assert message in str(err.value)
    assert str(err.value).startswith(str(path))


def test_collects_every_bad_row(tmp_path):
    path = tmp_path / "bad.tdx"
    path.write_text(TEXT.replace("0.0 -50 -4.0", "0.0 -50").replace("1.0 50 4.0", "1.0 inf 4"))
    problems = Problems()
    assert read_tydex(path, problems) is None
    lines = [str(p) for p in problems.finish()]
    assert lines == [f"{path}:16: ragged row: 2 values, 3 channels",
                     f"{path}:18: SLIPANGL: inf is not allowed (NaN/inf)"]
