"""Simulated Tire Test Consortium sessions for the TTC reader, segmentation and import tests."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io
from typer.testing import CliRunner

from identify.cli.app import app
from identify.io.common import Problems
from identify.io.tir import read_tir
from identify.io.ttc.files import TTC_CHANNELS, read_ttc
from identify.io.ttc.mat73 import write_mat73
from identify.simulate.default_tyre import default_tir_path
from identify.simulate.ttc import TtcSession, _write_dat, _write_mat, simulate_ttc


def import_refused(files: list[Path], out: Path) -> list[str]:
    """``mfid import FILES --out OUT`` that must refuse its input: asserts exit 2 and that
    nothing was written, and returns the lines it printed on stderr."""
    result = CliRunner().invoke(app, ["import", *map(str, files), "--out", str(out)])
    assert result.exit_code == 2 and not out.exists(), result.output
    return result.stderr.splitlines()


def read_clean(path: Path):
    """A TTC file read with read_ttc, asserting that it raised no problem."""
    problems = Problems()
    run = read_ttc(path, problems)
    assert problems.total == 0, [str(p) for p in problems.finish()]
    return run


def session(path: Path, **settings) -> TtcSession:
    """A session of the bundled 225/50 R17 tyre written to ``path``."""
    return simulate_ttc(read_tir(default_tir_path()).params(), path, **settings)


def _small_channels(drop=()):
    n = 200
    t = np.arange(n) / 100.0
    ch = {"ET": t, "V": np.full(n, 40.0), "N": np.full(n, 340.0), "SA": np.sin(t),
          "IA": np.zeros(n), "P": np.full(n, 83.0), "FX": np.zeros(n) + 5, "FY": 500 * np.sin(t),
          "FZ": np.full(n, -1000.0), "MX": np.ones(n), "MZ": np.ones(n), "SL": np.zeros(n)}
    return {k: v for k, v in ch.items() if k not in drop}


def small_mat(path, drop=(), units=None, struct=True):
    ch = _small_channels(drop)
    names = list(ch)
    content = {k: v.reshape(-1, 1) for k, v in ch.items()}
    if struct:
        u = {k: TTC_CHANNELS[k].si_unit for k in names} | dict(units or {})
        content["channel"] = {"name": np.array(names, dtype=object),
                              "units": np.array([u[k] for k in names], dtype=object)}
    scipy.io.savemat(path, content, format="5")
    return path


def small_mat73(path, drop=(), units=None, struct=True):
    """small_mat as a MATLAB v7.3 (HDF5) file."""
    ch = _small_channels(drop)
    u = {k: TTC_CHANNELS[k].si_unit for k in ch} | dict(units or {})
    cells = {"channel": {"name": list(ch), "units": [u[k] for k in ch]}} if struct else {}
    return write_mat73(path, ch, cells, {"tireid": "small"})


def _truncated(path, make=small_mat):
    data = make(path).read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return path


def _short_header(path):
    path.write_text("ET\tFZ\ns\tN\n0.0\t-1000\n0.01\t-1000\n")
    return path



#: Unusable TTC files: (id, maker(path) -> file, the one line InputError prints; "..." = starts).
UNUSABLE = [
    ("no-FZ", lambda p: small_mat(p, drop=("FZ",)), "{p}: FZ: missing required channel"),
    ("unknown-unit", lambda p: small_mat(p, units={"FY": "furlong"}),
     "{p}: FY: unknown unit 'furlong'"),
    ("wrong-dimension", lambda p: small_mat(p, units={"P": "N"}),
     "{p}: P: unit 'N' is a force unit, expected a pressure unit such as 'Pa'"),
    ("truncated-mat", _truncated, "{p}: truncated or corrupt .mat file (scipy.io: ..."),
    ("truncated-mat73", lambda p: _truncated(p, small_mat73),
     "{p}: truncated or corrupt MATLAB v7.3 .mat file (corrupt HDF5 inside ..."),
    ("mat73-no-FZ", lambda p: small_mat73(p, drop=("FZ",)), "{p}: FZ: missing required channel"),
    ("dat-short-header", lambda p: _short_header(p.with_suffix(".dat")),
     ("{p}:3: short header: a TTC .dat file has a title line, a line of channel names and a "
      "line of units before the data (found line 3 holds numbers)")),
]


def decimated(source: TtcSession, path: Path, factor: int) -> list[Path]:
    """Every ``factor``-th sample of a session's runs, written as .mat and .dat in the TTC
    layout to ``path`` with the generator's own writers (a shorter session of the same
    programme, for the default suite)."""
    path.mkdir(parents=True, exist_ok=True)
    out = []
    for mat in (f for f in source.files if f.suffix == ".mat"):
        raw = scipy.io.loadmat(mat, squeeze_me=True)
        names = [str(n) for n in raw["channel"]["name"].item()]
        units = dict(zip(names, (str(u) for u in raw["channel"]["units"].item())))
        ch = {n: np.asarray(raw[n], dtype=float)[::factor] for n in names}
        strings = {k: str(raw[k]) for k in ("source", "testid", "tireid")}
        _write_mat(path / mat.name, ch, units, strings)
        _write_dat(path / f"{mat.stem}.dat", f"{mat.stem} decimated x{factor}", ch, units)
        out += [path / mat.name, path / f"{mat.stem}.dat"]
    return out
