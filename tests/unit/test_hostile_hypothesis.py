"""Every reader, fed mutated files, raises only the project's error, always on one line.

A valid file of each format is mutated by hypothesis (hostile tokens spliced in at random
places: NaN, inf, huge numbers, separators, quotes, line breaks, NUL and non-UTF-8 bytes,
long cells; random bytes into the binary formats) and read with the reader that `mfid` uses
for it. Any exception but :class:`~identify.core.errors.InputError` fails, and so does an
error or a collected problem whose text spans more than one line (issue 15, acceptance 3).
The default suite runs a few dozen cases per reader; ``-m trials`` runs 10,000 per reader.
"""
from __future__ import annotations

import atexit
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from identify.core.errors import InputError
from identify.io.common import Problems
from identify.io.hdf5.channel_files import RawRun, write_hdf5
from identify.io.manifest import read_manifest
from identify.io.tables.characteristics import read_characteristics
from identify.io.tables.points import read_points
from identify.io.tir import read_tir
from identify.io.trailer.files import channels_to_tidy, read_channels
from identify.io.ttc.files import TTC_CHANNELS
from identify.io.ttc.mat73 import write_mat73
from identify.io.tydex import TydexChannel, TydexEntry, TydexFile, write_tydex
from tests.measurement_cases import CHARACTERISTICS, POINTS, TIR, TOML, trailer_channels

TOKENS = ["nan", "NaN", "inf", "-inf", "1e308", "1e309", "-1e308", "1e-320", "0", "-0", "-1",
          "", ",", ",,", ";", "\t", " ", "\n", "\r\n", "\r", '"', '""', "'", "\x00", "=",
          "[", "]", "[[", "{", "}", "#", "!", "$", "**END", "**HEADER", "**MEASURDATA",
          "[MODEL]", "[VERTICAL]", "FITTYP = 61", "FNOMIN = 0", "9" * 400, "x" * 140_000,
          "é", "\udcff", "\ufeff", "1.2.3", "0x10", "1_000", "true", "id = ''", "../../x",
          "kind = 'trailer'", "units = { FZW = 'kN' }", "[deg]", "[kPa]", " [bar]"]


def _edits():
    token = st.one_of(st.sampled_from(TOKENS), st.text(max_size=12))
    return st.lists(st.tuples(st.floats(0, 1), st.integers(0, 20), token), min_size=1,
                    max_size=6)


def _apply(text: str, edits) -> bytes:
    for where, cut, token in edits:
        i = int(where * len(text))
        text = text[:i] + token + text[i + cut:]
    return text.encode("utf-8", "surrogateescape")


def _flip(data: bytes, edits) -> bytes:
    out = bytearray(data)
    for where, value in edits:
        out[min(int(where * len(out)), len(out) - 1)] = value
    return bytes(out)


def _one_line(text: str) -> None:
    assert "\n" not in text and "\r" not in text, repr(text)


def _run(fn) -> None:
    """Call ``fn``; only InputError may escape, and its text is one line. A RuntimeWarning
    (numpy's overflow or invalid-value text, which would reach the user's terminal as is)
    fails too."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            problems = fn()
    except InputError as exc:
        _one_line(str(exc))
        return
    for problem in problems or []:
        _one_line(str(problem))


# ------------------------------------------------------------------ valid files

def _csv() -> str:
    ch = trailer_channels()
    names = list(ch)
    rows = [",".join(repr(float(ch[n][i])) for n in names) for i in range(ch["RUNTIME"].size)]
    return "\n".join([",".join(names), *rows]) + "\n"


def _tdx(path: Path) -> str:
    ch = trailer_channels()
    write_tydex(path, TydexFile((TydexEntry("MEASID", "Measurement ID", "", "r"),), ("c",), (),
                                tuple(TydexChannel(k, k.lower(), "") for k in ch),
                                np.column_stack(list(ch.values()))))
    return path.read_text()


def _h5(path: Path) -> bytes:
    write_hdf5(path, [RawRun("r", trailer_channels(), {"SLIPANGL": "rad"})])
    return path.read_bytes()


def _ttc_channels() -> dict[str, np.ndarray]:
    n = 60
    t = np.arange(n) / 100.0
    return {"ET": t, "V": np.full(n, 40.0), "N": np.full(n, 340.0), "SA": np.sin(t),
            "IA": np.zeros(n), "P": np.full(n, 83.0), "FX": np.zeros(n) + 5,
            "FY": 500 * np.sin(t), "FZ": np.full(n, -1000.0), "MX": np.ones(n),
            "MZ": np.ones(n), "SL": np.zeros(n)}


def _mat(path: Path) -> bytes:
    ch = _ttc_channels()
    content = {k: v.reshape(-1, 1) for k, v in ch.items()}
    content["channel"] = {"name": np.array(list(ch), dtype=object),
                          "units": np.array([TTC_CHANNELS[k].si_unit for k in ch],
                                            dtype=object)}
    scipy.io.savemat(path, content, format="5")
    return path.read_bytes()


def _mat73(path: Path) -> bytes:
    ch = _ttc_channels()
    write_mat73(path, ch, {"channel": {"name": list(ch),
                                       "units": [TTC_CHANNELS[k].si_unit for k in ch]}},
                {"tireid": "t"})
    return path.read_bytes()


def _dat() -> str:
    ch = _ttc_channels()
    lines = ["run 1", "\t".join(ch), "\t".join(TTC_CHANNELS[k].si_unit for k in ch)]
    lines += ["\t".join(repr(float(v[i])) for v in ch.values()) for i in range(60)]
    return "\n".join(lines) + "\n"


TMP = Path(tempfile.mkdtemp(prefix="mfid-hypothesis-"))
atexit.register(shutil.rmtree, TMP, True)  # the mutated files go with the session
BASE = {"csv": _csv(), "tdx": _tdx(TMP / "base.tdx"), "toml": TOML, "table": CHARACTERISTICS,
        "tir": TIR.read_text(), "points": POINTS, "dat": _dat()}
BINARY = {"h5": _h5(TMP / "base.h5"), "mat": _mat(TMP / "base.mat"),
          "mat73": _mat73(TMP / "base73.mat")}


def _trailer(path: Path):
    problems = Problems()
    runs = read_channels(path, problems=problems) or []
    for ch in runs:
        channels_to_tidy(ch, problems=problems, warnings=[])
    return problems.finish()


def _strict_trailer(path: Path):
    for ch in read_channels(path) or []:
        channels_to_tidy(ch)


def _collected(read):
    """A reader with a collector -> a function of the path returning the problems."""
    def run(path: Path):
        problems = Problems()
        read(path, problems)
        return problems.finish()
    return run


def _raising(read):
    """A strict reader -> a function of the path returning no problems (it raises)."""
    def run(path: Path):
        read(path)
        return []
    return run


READERS = {
    "toml": ("tyre.toml", _collected(lambda p, pr: read_manifest(p, pr, partial=True,
                                                                  warnings=[]))),
    "csv": ("run.csv", _trailer),
    "tdx": ("run.tdx", _trailer),
    "table": ("table.csv", _collected(lambda p, pr: read_characteristics(
        p, problems=pr, warnings=[]))),
    "tir": ("t.tir", _raising(read_tir)),
    "points": ("points.csv", _raising(read_points)),
    "dat": ("run.dat", _trailer),
    "h5": ("run.h5", _trailer),
    "mat": ("run.mat", _trailer),
    "mat73": ("run.mat", _trailer),
}
STRICT = {"csv": _strict_trailer, "tdx": _strict_trailer, "dat": _strict_trailer,
          "h5": _strict_trailer, "mat": _strict_trailer, "mat73": _strict_trailer,
          "toml": _raising(read_manifest), "table": _raising(read_characteristics)}


def _case(kind: str, data: bytes) -> None:
    path = TMP / kind / READERS[kind][0]
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(data)
    _run(lambda: READERS[kind][1](path))
    if kind in STRICT:
        _run(lambda: STRICT[kind](path))


def _text_test(kind: str, n: int):
    @settings(max_examples=n, deadline=None, derandomize=n < 1000,
              suppress_health_check=list(HealthCheck))
    @given(edits=_edits())
    def run(edits):
        _case(kind, _apply(BASE[kind], edits))
    return run


def _binary_test(kind: str, n: int):
    @settings(max_examples=n, deadline=None, derandomize=n < 1000,
              suppress_health_check=list(HealthCheck))
    @given(edits=st.lists(st.tuples(st.floats(0, 1), st.integers(0, 255)), min_size=1,
                          max_size=8), cut=st.one_of(st.none(), st.floats(0, 1)))
    def run(edits, cut):
        data = _flip(BINARY[kind], edits)
        _case(kind, data if cut is None else data[:int(cut * len(data))])
    return run


def _test(kind: str, n: int):
    return _binary_test(kind, n) if kind in BINARY else _text_test(kind, n)


#: Cases per reader in the default suite (the whole file stays under ~30 s).
QUICK = {"toml": 60, "csv": 30, "tdx": 30, "table": 60, "tir": 60, "points": 60, "dat": 30,
         "h5": 40, "mat": 40, "mat73": 30}


def test_the_base_files_are_valid():
    for kind in READERS:
        data = BINARY[kind] if kind in BINARY else BASE[kind].encode()
        path = TMP / kind / READERS[kind][0]
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(data)
        assert not READERS[kind][1](path), kind


@pytest.mark.parametrize("kind", list(READERS))
def test_reader_raises_only_one_line_input_errors(kind):
    _test(kind, QUICK[kind])()
