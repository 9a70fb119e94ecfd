"""A small, valid measurement folder for loader and ``mfid check`` tests.

The folder holds every kind of run and every trailer format: two raw Flatplank runs (parking
at 5 kN and a camber run), trailer cornering sweeps as CSV (ISO-W), HDF5 (ISO-W) and TYDEX
(SAE), a characteristic table listed in the manifest, an eigenfrequency table found at the root
(``characteristics.csv``), plus a .tir file and operating points used by the ``mfid eval``
part of the no-modification test.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from identify.io.hdf5.channel_files import RawRun, write_hdf5
from identify.io.tydex import TydexChannel, TydexEntry, TydexFile, write_tydex
from identify.simulate.manifest import toml_value

TIR = Path(__file__).parent / "data" / "tir" / "testA_61.tir"
SAMPLE = Path(__file__).resolve().parents[1] / "measurements" / "sample-225-50R17"
TRAILER_NAMES = ("RUNTIME", "LONGVEL", "WHROTSPD", "SLIPANGL", "LONGSLIP", "INCLANGL",
                 "INFLPRES", "FX", "FYW", "FZW", "MXW", "MYW", "MZW")
FLATPLANK_NAMES = ("time", "Gx1", "Gx2", "Gy", "Gz1", "Gz2", "plank_x", "wheel_angle", "psi",
                   "hub_z", "phi_wheel", "phi_plank", "loaded_radius")

# Files of the good folder (relative to it) that the bad-input tests edit
FP = "flatplank/parking_p250_fz5000_s1.csv"
TR = "trailer/cornering_p250.csv"
H5 = "trailer/cornering_p220.h5"
TDX = "trailer/cornering_p280.tdx"
TAB = "tables/thesis.csv"
PTS = "extra/points.csv"

#: The manifest's runs, in order: ``key = value`` lines of each ``[[runs]]`` table
RUNS = (
    {"file": FP, "kind": "flatplank", "test": "parking",
     "conditions": {"pressure_Pa": 250000, "load_N": 5000, "start_position": 1}},
    {"file": "flatplank/camber_p250_fz5000_s1_g5.csv", "kind": "flatplank", "test": "camber",
     "units": {"phi_plank": "deg"},
     "conditions": {"pressure_Pa": 250000, "load_N": 5000, "start_position": 1,
                    "gamma_deg": 5.0}},
    {"file": TR, "kind": "trailer", "test": "cornering",
     "axes": "ISO-W", "units": {"SLIPANGL": "deg", "INFLPRES": "kPa"},
     "conditions": {"pressure_Pa": 250000, "load_N": 5000}},
    {"id": "cornering_p220", "file": H5, "kind": "trailer",
     "test": "cornering", "conditions": {"pressure_Pa": 220000, "load_N": 5000}},
    {"file": TDX, "kind": "trailer", "test": "cornering", "axes": "SAE",
     "conditions": {"pressure_Pa": 280000, "load_N": 5000}},
    {"id": "thesis", "file": TAB, "kind": "characteristics", "test": "any"},
)

TOML = """\
[tyre]
id = "225-50R17-test"
nominal_pressure_Pa = 250000
nominal_load_N = 5000
unloaded_radius_m = 0.3205
source = "simulated"

[rig]
hub_a_m = 0.08
hub_b_m = 0.05
""" + "".join("\n[[runs]]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in run.items())
              for run in RUNS)

CHARACTERISTICS = """\
quantity,pi_bar,Fz_N,value,unit
CFz,2.5,5000,251700.0,N/m
CFy,2.5,5000,145.2,N/mm
sigma_y,2.5,5000,385.0,mm
Re,2.5,5000,0.3135,m
"""

EIGEN = """\
quantity,pi_bar,Fz_N,value,unit,mode
f_nat,2.5,0,42.5,Hz,z
f_nat,2.5,0,80.1,Hz,x
"""

POINTS = "Fz,kappa,alpha,gamma,Vx,p\n5000,0.0,0.05,0.0,16.7,250000\n4000,0.02,0.0,0.0,16.7,250000\n"


def trailer_channels(n: int = 41, *, pressure: float = 250000.0, seed: int = 0
                     ) -> dict[str, np.ndarray]:
    """A cornering sweep in ISO-W and SI: Fy < 0 and Mz > 0 at positive slip angle."""
    rng = np.random.default_rng(seed)
    alpha = np.linspace(-0.1, 0.1, n)
    return {
        "RUNTIME": np.linspace(0.0, 4.0, n), "LONGVEL": np.full(n, 16.7),
        "WHROTSPD": np.full(n, 16.7 / 0.31), "SLIPANGL": alpha, "LONGSLIP": np.zeros(n),
        "INCLANGL": np.zeros(n), "INFLPRES": np.full(n, pressure),
        "FX": -50.0 + rng.normal(0, 5, n), "FYW": -60000.0 * np.tanh(alpha / 0.08) / 12.0,
        "FZW": 5000.0 + rng.normal(0, 20, n), "MXW": 300.0 * np.sin(alpha * 10),
        "MYW": np.full(n, -60.0), "MZW": 1800.0 * np.sin(alpha * 15) * np.exp(-alpha ** 2 * 200),
    }


def flatplank_channels(n: int = 31, *, load: float = 5000.0, phi_plank: float = 0.0,
                       seed: int = 1) -> dict[str, np.ndarray]:
    """A raw parking-like run: psi sweep at constant contact load ``load`` [N]."""
    rng = np.random.default_rng(seed)
    psi = np.linspace(-0.1, 0.1, n)
    g = phi_plank
    kz = load * np.cos(g) + rng.normal(0, 5, n)
    return {
        "time": np.linspace(0.0, 30.0, n), "Gx1": 200.0 * psi, "Gx2": -150.0 * psi,
        "Gy": -load * np.sin(g) + 10.0 * psi, "Gz1": 0.4 * kz, "Gz2": 0.6 * kz,
        "plank_x": np.zeros(n), "wheel_angle": np.zeros(n), "psi": psi, "hub_z": np.full(n, 0.02),
        "phi_wheel": np.zeros(n), "phi_plank": np.full(n, g), "loaded_radius": np.full(n, 0.3),
    }


def write_csv(path: Path, columns: dict[str, np.ndarray], header: list[str] | None = None) -> Path:
    """A plain CSV, exact (repr) numbers; ``header`` replaces the column names if given."""
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(columns)
    rows = np.column_stack([columns[k] for k in names]).tolist()
    lines = [",".join(header or names)] + [",".join(map(repr, r)) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_good_folder(root: Path) -> Path:
    """Create the valid folder under ``root`` and return it."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "tyre.toml").write_text(TOML)
    write_csv(root / FP, flatplank_channels())
    camber = flatplank_channels(phi_plank=np.radians(5.0), seed=2)
    camber["phi_plank"] = np.degrees(camber["phi_plank"])
    write_csv(root / "flatplank" / "camber_p250_fz5000_s1_g5.csv", camber)
    ch = trailer_channels(pressure=250000.0)
    ch["SLIPANGL"] = np.degrees(ch["SLIPANGL"])
    ch["INFLPRES"] = ch["INFLPRES"] / 1000.0
    write_csv(root / TR, ch)
    h5 = trailer_channels(pressure=220000.0, seed=3)
    write_hdf5(root / H5,
               [RawRun("cornering_p220", h5, {"SLIPANGL": "rad", "INFLPRES": "Pa"})])
    sae = trailer_channels(pressure=280000.0, seed=4)
    for key in ("FYW", "FZW", "MYW", "MZW", "SLIPANGL"):
        sae[key] = -sae[key]
    units = {"RUNTIME": "s", "LONGVEL": "km/h", "SLIPANGL": "deg", "INFLPRES": "bar"}
    sae["LONGVEL"] = sae["LONGVEL"] * 3.6
    sae["SLIPANGL"] = np.degrees(sae["SLIPANGL"])
    sae["INFLPRES"] = sae["INFLPRES"] / 1e5
    write_tydex(root / TDX, TydexFile(
        (TydexEntry("MEASID", "Measurement ID", "", "cornering_p280"),), ("test file",), (),
        tuple(TydexChannel(k, k.lower(), units.get(k, "")) for k in sae),
        np.column_stack(list(sae.values()))))
    (root / "tables").mkdir(exist_ok=True)
    (root / TAB).write_text(CHARACTERISTICS)
    (root / "characteristics.csv").write_text(EIGEN)
    (root / "extra").mkdir(exist_ok=True)
    shutil.copy(TIR, root / "extra" / "tyre.tir")
    (root / PTS).write_text(POINTS)
    return root


def sample_trailer_folder(folder: Path) -> Path:
    """The bundled sample's trailer runs alone, as a measurement folder at ``folder``: its
    tyre.toml (the [tyre] and [rig] tables, the trailer runs' entries) and trailer files. Its
    trailer table is the sample's, without reading the sample's 735 Flatplank files."""
    head, *runs = (SAMPLE / "tyre.toml").read_text().split("[[runs]]")
    keep = [r for r in runs if 'kind = "trailer"' in r]
    (folder / "trailer").mkdir(parents=True)
    (folder / "tyre.toml").write_text(head + "".join("[[runs]]" + r for r in keep))
    for r in keep:
        name = r.split('file = "')[1].split('"')[0]
        shutil.copy(SAMPLE / name, folder / name)
    return folder


def rewrite_lines(rel: str, change):
    """A folder edit for the bad-input tests: the lines of the text file ``rel`` (relative to
    the folder) replaced by ``change(lines)``, written back with ``\n`` line ends."""
    def apply(root: Path) -> None:
        path = root / rel
        path.write_text("\n".join(change(path.read_text().splitlines())) + "\n")
    return apply


def set_cell(rel: str, line: int, column: str, value: str):
    """A folder edit for the bad-input tests: cell ``column`` of 1-based ``line`` of the CSV
    ``rel`` (relative to the folder) set to ``value`` as text."""
    def change(lines: list[str]) -> list[str]:
        col = lines[0].split(",").index(column)
        cells = lines[line - 1].split(",")
        cells[col] = value
        lines[line - 1] = ",".join(cells)
        return lines
    return rewrite_lines(rel, change)


def edit(rel: str, old: str | bytes, new: str | bytes, count: int = 1):
    """A folder edit for the bad-input tests: the first ``count`` occurrences of ``old`` in
    the file ``rel`` replaced by ``new`` (text, or bytes for bytes that are not UTF-8); the
    file must hold ``old``."""
    def apply(root: Path) -> None:
        path = root / rel
        data = path.read_bytes() if isinstance(old, bytes) else path.read_text()
        assert old in data, (rel, old)
        if isinstance(old, bytes):
            path.write_bytes(data.replace(old, new, count))
        else:
            path.write_text(data.replace(old, new, count))
    return apply


def dead_pid() -> int:
    """A process id that no process runs under: a child that has exited and been reaped
    (a subprocess, not a fork, which is unsafe once JAX has started its threads)."""
    child = subprocess.Popen([sys.executable, "-c", ""])
    child.wait()
    return child.pid
