"""The hostile-input corpus (issue 15): every bad input is one line naming the file, exit 2.

Each case mutates a copy of the good folder (tests/measurement_cases.py), runs one command
(check, eval, convert, fit) and asserts: exit 2, exactly one error line, which names the file
(and the line or channel where there is one) and says what is wrong; no traceback. The classes:
unsafe names and paths, what the libraries raise (csv field limit, h5py, symlink loops, huge
numbers, undecodable bytes, multi-line quoted cells), values that are only wrong after the unit
conversion or a channel factor, implausible values, .tir keys the model divides by, a .tir
section header lost (its keys read as part of the section above), files that are not regular
files (FIFOs, devices). A case accepted with exit 0 fails the test.
"""
from __future__ import annotations

import os
import shutil
import struct
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io
from typer.testing import CliRunner

from identify.cli.app import app
from identify.io.common import Problems
from identify.io.hdf5 import probe as hdf5_probe
from identify.io.hdf5.channel_files import RawRun, write_hdf5
from identify.io.trailer.files import read_channels
from tests.measurement_cases import (
    FP,
    H5,
    PTS,
    TAB,
    TDX,
    TR,
    edit,
    rewrite_lines,
    trailer_channels,
    write_good_folder,
)
from tests.measurement_cases import set_cell as cell
from tests.ttc_cases import small_mat, small_mat73

runner = CliRunner()
TIR = "extra/tyre.tir"
TR_CONDITIONS = "conditions = { pressure_Pa = 250000, load_N = 5000 }\n"


# ------------------------------------------------------------------ mutations

def column(rel: str, name: str, fn):
    def change(lines: list[str]) -> list[str]:
        col = lines[0].split(",").index(name)
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            cells[col] = repr(fn(float(cells[col])))
            out.append(",".join(cells))
        return out
    return rewrite_lines(rel, change)


def indexed(rel: str, name: str, fn):
    """Every cell of column ``name`` set to ``fn(i, value)`` (``i``: the row), as text when
    ``fn`` gives a str, else as its repr."""
    def change(lines: list[str]) -> list[str]:
        col = lines[0].split(",").index(name)
        out = [lines[0]]
        for i, line in enumerate(lines[1:]):
            cells = line.split(",")
            value = fn(i, float(cells[col]))
            cells[col] = value if isinstance(value, str) else repr(value)
            out.append(",".join(cells))
        return out
    return rewrite_lines(rel, change)


def cr_only(rel: str):
    def apply(root: Path) -> None:
        path = root / rel
        path.write_bytes(path.read_bytes().replace(b"\r\n", b"\r").replace(b"\n", b"\r"))
    return apply


def raw_line(rel: str, line: int, data: bytes):
    def apply(root: Path) -> None:
        lines = (root / rel).read_bytes().split(b"\n")
        lines[line - 1] = data
        (root / rel).write_bytes(b"\n".join(lines))
    return apply


def tir_key(key: str, value: str):
    def change(lines: list[str]) -> list[str]:
        i = next(i for i, x in enumerate(lines) if x.split("=")[0].strip() == key)
        lines[i] = f"{key} = {value}"
        return lines
    return rewrite_lines(TIR, change)


def both(*fns):
    def apply(root: Path) -> None:
        for fn in fns:
            fn(root)
    return apply


def fifo(rel: str):
    def apply(root: Path) -> None:
        (root / rel).unlink()
        os.mkfifo(root / rel)
    return apply


def symlink(rel: str, target):
    def apply(root: Path) -> None:
        to = target(root) if callable(target) else target
        (root / rel).unlink()
        (root / rel).symlink_to(to)
    return apply


def outside_file(root: Path) -> Path:
    target = root.parent / "outside.csv"
    shutil.copy(root / TR, target)
    return target


def h5_rewrite(fn):
    def apply(root: Path) -> None:
        with h5py.File(root / H5, "r+") as fh:
            fn(fh["cornering_p220"])
    return apply


def h5_empty(grp) -> None:
    for key in list(grp):
        del grp[key]
        grp.create_dataset(key, data=np.zeros(0))


def h5_dangling(grp) -> None:
    del grp["FYW"]
    grp["FYW"] = h5py.SoftLink("/nowhere/FYW")


def h5_overflow(grp) -> None:
    grp["INFLPRES"].attrs["units"] = "kPa"
    grp["INFLPRES"][4] = 1e308


def overwrite(rel: str, offset: int, size: int = 64):
    """Bytes of a file overwritten in place (HDF5 metadata that h5py opens, then fails on)."""
    def apply(root: Path) -> None:
        data = bytearray((root / rel).read_bytes())
        data[offset:offset + size] = b"\xa5" * size
        (root / rel).write_bytes(bytes(data))
        with h5py.File(root / rel, "r") as fh:  # still opens: the damage is further in
            assert list(fh)
    return apply


def ttc_mat_overflow(root: Path) -> None:
    """A TTC .mat file whose pressure in psi is finite as stored, infinite in Pa."""
    path = small_mat(root / "extra" / "session.mat", units={"P": "psi"})
    raw = scipy.io.loadmat(path)
    raw["P"][4, 0] = 1e308
    scipy.io.savemat(path, {k: v for k, v in raw.items() if not k.startswith("__")},
                     format="5")


def ttc_mat_bad_type(root: Path) -> None:
    """A TTC .mat file whose first data element has a type code scipy.io has no reader for
    (scipy.io dies with a segmentation fault on it)."""
    path = small_mat(root / "extra" / "session.mat")
    data = bytearray(path.read_bytes())
    at = data.find(struct.pack("<II", 9, 200 * 8))  # miDOUBLE, 200 samples: the ET vector
    assert at > 128
    data[at] = 200
    path.write_bytes(bytes(data))


def ttc_mat_logical(name: str, version: str = "5"):
    """A TTC .mat file whose channel ``name`` is a MATLAB logical (true in every sample)."""
    def apply(root: Path) -> None:
        path = root / "extra" / "session.mat"
        if version == "7.3":
            small_mat73(path)
            with h5py.File(path, "r+") as fh:
                n = fh[name].shape[1]
                del fh[name]
                ds = fh.create_dataset(name, data=np.ones((1, n), np.uint8))
                ds.attrs["MATLAB_class"] = np.bytes_("logical")
            return
        raw = scipy.io.loadmat(small_mat(path))
        raw[name] = np.ones_like(raw[name], dtype=bool)
        scipy.io.savemat(path, {k: v for k, v in raw.items() if not k.startswith("__")},
                         format="5")
    return apply


def truncate(rel: str, keep: int):
    def apply(root: Path) -> None:
        data = (root / rel).read_bytes()
        (root / rel).write_bytes(data[:keep])
    return apply


def tdx_constant_nan(root: Path) -> None:
    text = (root / TDX).read_text()
    text = text.replace("INFLPRES  inflpres", "XINFLPRES inflpres", 1)
    text = text.replace("**CONSTANTS\n", "**CONSTANTS\n" + "INFLPRES".ljust(10)
                        + "inflation pressure".ljust(30) + "bar".ljust(10) + "nan\n", 1)
    (root / TDX).write_text(text)


nothing = both()
BIG = "9" * 200_000
ROOT_CMD = ["check", "{root}"]
EVAL = ["eval", "{root}/" + TIR, "-i", "{root}/" + PTS, "-o", "{out}/eval.csv"]
FIT = ["fit", "{root}", "--out", "{out}/f", "--reports", "{out}/r"]


# ------------------------------------------------------------------ the corpus
# (id, mutation, command (with {root} and {out}), file the line names, the rest of the line:
#  fragments that must all appear, in order, after the file)
CASES = [
    # names and paths
    ("id-dotdot", edit("tyre.toml", '"225-50R17-test"', '"../../escaped_by_id"'), ROOT_CMD,
     "tyre.toml", ["tyre.id: ", "not a safe file name"]),
    ("id-empty", edit("tyre.toml", '"225-50R17-test"', '""'), ROOT_CMD, "tyre.toml",
     ["tyre.id: ", "not a safe file name"]),
    ("id-dot", edit("tyre.toml", '"225-50R17-test"', '"."'), ROOT_CMD, "tyre.toml",
     ["tyre.id: ", "not a safe file name"]),
    ("id-slash", edit("tyre.toml", '"225-50R17-test"', '"a/b"'), ROOT_CMD, "tyre.toml",
     ["tyre.id: ", "not a safe file name"]),
    ("id-space", edit("tyre.toml", '"225-50R17-test"', '"x y"'), ROOT_CMD, "tyre.toml",
     ["tyre.id: ", "not a safe file name"]),
    ("id-newline", edit("tyre.toml", '"225-50R17-test"', '"a\\nb"'), ROOT_CMD, "tyre.toml",
     ["tyre.id: ", "not a safe file name"]),
    ("run-file-dotdot", both(outside_file, edit("tyre.toml", f'"{TR}"', '"../outside.csv"')),
     ROOT_CMD, "tyre.toml", ["runs[2].file: ", "leads outside the measurement folder"]),
    ("run-file-absolute", both(outside_file, edit("tyre.toml", f'"{TR}"', '"/etc/passwd"')),
     ROOT_CMD, "tyre.toml", ["runs[2].file: ", "an absolute path is not allowed"]),
    ("run-file-symlink-out", symlink(TR, outside_file), ROOT_CMD, "tyre.toml",
     ["runs[2].file: ", "leads outside the measurement folder"]),
    ("run-file-symlink-loop", symlink(TR, lambda root: root / TR), ROOT_CMD, "tyre.toml",
     ["runs[2].file: ", "cannot resolve"]),
    ("run-file-dangling", symlink(TR, lambda root: root / "trailer" / "gone.csv"), ROOT_CMD,
     "tyre.toml", ["runs[2].file: ", "dangling symbolic link"]),
    ("run-file-fifo", fifo(TR), ROOT_CMD, "tyre.toml",
     ["runs[2].file: ", "is a named pipe (FIFO)"]),
    ("run-file-fifo-table", fifo(TAB), ROOT_CMD, "tyre.toml",
     ["runs[5].file: ", "is a named pipe (FIFO)"]),
    ("manifest-fifo", fifo("tyre.toml"), ROOT_CMD, "tyre.toml", ["is a named pipe (FIFO)"]),
    ("check-dev-null", nothing, ["check", "/dev/null"], "/dev/null", ["is a device"]),
    ("check-fifo", lambda root: os.mkfifo(root / "pipe.csv"), ["check", "{root}/pipe.csv"],
     "pipe.csv", ["is a named pipe (FIFO)"]),
    # tyre.toml numbers
    ("toml-huge-integer", edit("tyre.toml", "nominal_load_N = 5000", "nominal_load_N = 1"
                               + "0" * 400), ROOT_CMD, "tyre.toml",
     ["tyre.nominal_load_N: ", "number too large"]),
    ("toml-pressure-1e308", edit("tyre.toml", "nominal_pressure_Pa = 250000",
                                 "nominal_pressure_Pa = 1e308"), ROOT_CMD, "tyre.toml",
     ["tyre.nominal_pressure_Pa: ", "not physical"]),
    ("toml-radius-1e-300", edit("tyre.toml", "unloaded_radius_m = 0.3205",
                                "unloaded_radius_m = 1e-300"), ROOT_CMD, "tyre.toml",
     ["tyre.unloaded_radius_m: ", "not physical"]),
    ("toml-radius-50", edit("tyre.toml", "unloaded_radius_m = 0.3205",
                            "unloaded_radius_m = 50.0"), ROOT_CMD, "tyre.toml",
     ["tyre.unloaded_radius_m: ", "not physical"]),
    ("toml-load-2e6", edit("tyre.toml", TR_CONDITIONS, "conditions = { pressure_Pa = 250000, "
                           "load_N = 2e6 }\n"), ROOT_CMD, "tyre.toml",
     ["runs[2].conditions.load_N: ", "not physical"]),
    ("toml-gamma-1000deg", edit("tyre.toml", "gamma_deg = 5.0", "gamma_deg = 1000.0"),
     ROOT_CMD, "tyre.toml", ["runs[1].conditions.gamma_deg: ", "not physical"]),
    ("toml-speed-1e4", edit("tyre.toml", TR_CONDITIONS, "conditions = { pressure_Pa = 250000, "
                            "load_N = 5000, speed_mps = 1e4 }\n"), ROOT_CMD, "tyre.toml",
     ["runs[2].conditions.speed_mps: ", "not physical"]),
    ("toml-not-utf8", raw_line("tyre.toml", 3, b"nominal_pressure_Pa = 250000 # \xff\xfe"),
     ROOT_CMD, "tyre.toml", [":3: ", "not UTF-8 text"]),
    ("toml-deep-nesting", edit("tyre.toml", "[rig]", "x = " + "[" * 5000 + "]" * 5000
                               + "\n[rig]"), ROOT_CMD, "tyre.toml", ["invalid TOML"]),
    # trailer CSV
    ("csv-cell-over-field-limit", cell(TR, 5, "FYW", BIG), ROOT_CMD, TR,
     [":5: ", "cannot parse CSV: field larger than field limit"]),
    ("csv-header-over-field-limit", raw_line(TR, 1, b'"' + b"A" * 200_000 + b'"'), ROOT_CMD,
     TR, [":1: ", "cannot parse the header"]),
    ("csv-multiline-quoted-cell", cell(TR, 5, "FYW", '"12\n34"'), ROOT_CMD, TR,
     [":5: FYW: ", "not a number: '12\\n34'"]),
    ("csv-not-utf8", raw_line(TR, 6, b"0.5,16.7,53.8,-5.0,0.0,0.0,250.0,\xff\xfe,1,1,1,1,1"),
     ROOT_CMD, TR, [":6: FX: ", "not UTF-8 text"]),
    ("csv-overflow-after-kpa", cell(TR, 5, "INFLPRES", "1e308"), ROOT_CMD, TR,
     [":5: INFLPRES: ", "not finite in SI"]),
    ("csv-negative-pressure-no-nominal", both(
        edit("tyre.toml", TR_CONDITIONS, "\n"), column(TR, "INFLPRES", lambda v: -v)),
     ROOT_CMD, TR, ["INFLPRES: ", "median pressure", "not physical"]),
    ("csv-zero-load", both(edit("tyre.toml", TR_CONDITIONS, "\n"),
                           column(TR, "FZW", lambda v: 0.0)), ROOT_CMD, TR,
     ["FZW: ", "median Fz is 0 N"]),
    ("csv-pressure-too-high", both(edit("tyre.toml", TR_CONDITIONS, "\n"),
                                   column(TR, "INFLPRES", lambda v: v * 1e5)), ROOT_CMD, TR,
     ["INFLPRES: ", "not physical"]),
    ("csv-load-too-high", both(edit("tyre.toml", TR_CONDITIONS, "\n"),
                               column(TR, "FZW", lambda v: v * 1e4)), ROOT_CMD, TR,
     ["FZW: ", "not physical"]),
    ("csv-degrees-as-radians", both(edit("tyre.toml", 'SLIPANGL = "deg"', 'SLIPANGL = "rad"'),
                                    column(TR, "SLIPANGL", lambda v: 3 * v)), ROOT_CMD, TR,
     ["SLIPANGL: ", "not physical", "degrees given as radians?"]),
    ("csv-kmh-as-ms", column(TR, "LONGVEL", lambda v: 100 * v), ROOT_CMD, TR,
     ["LONGVEL: ", "median speed", "not physical"]),
    # values no rig produces, channels that hold none (issue 44)
    ("csv-boolean-channel", indexed(TR, "INCLANGL", lambda i, v: "True"), FIT, TR,
     [":2: INCLANGL: ", "not a number: 'True'"]),
    ("csv-required-channel-all-nan", indexed(TR, "FYW", lambda i, v: "nan"), ROOT_CMD, TR,
     ["FYW: ", "no finite value (all 41 samples are NaN/inf)"]),
    ("csv-force-1e300", indexed(TR, "FX", lambda i, v: 1e300), ROOT_CMD, TR,
     [":2: FX: ", "largest force 1e+300 N is not physical"]),
    ("csv-moment-1e8", indexed(TR, "MXW", lambda i, v: 1e8), ROOT_CMD, TR,
     [":2: MXW: ", "largest moment 1e+08 N m is not physical"]),
    ("csv-time-step-1e-300", indexed(TR, "RUNTIME", lambda i, v: i * 1e-300), ROOT_CMD, TR,
     ["RUNTIME: ", "median time step 1e-300 s is not physical"]),
    ("csv-time-step-1e4", indexed(TR, "RUNTIME", lambda i, v: i * 1e4), ROOT_CMD, TR,
     ["RUNTIME: ", "median time step 10000 s is not physical"]),
    ("csv-time-1e300", indexed(TR, "RUNTIME", lambda i, v: 1e300 * (1 + i * 1e-6)), ROOT_CMD,
     TR, ["RUNTIME: ", "largest time", "is not physical"]),
    ("csv-slip-ratio-1e5", indexed(TR, "LONGSLIP", lambda i, v: 1e5 if i < 11 else 0.0),
     ROOT_CMD, TR, [":2: LONGSLIP: ", "largest slip 100000 is not physical"]),
    ("flatplank-force-1e300", indexed(FP, "Gz1", lambda i, v: 1e300), FIT, FP,
     [":2: Gz1: ", "largest force 1e+300 N is not physical"]),
    ("flatplank-time-step-1e-300", indexed(FP, "time", lambda i, v: i * 1e-300), ROOT_CMD, FP,
     ["time: ", "median time step 1e-300 s is not physical"]),
    ("csv-cr-only-line-ends", cr_only(TR), ROOT_CMD, TR,
     [":1: ", "its lines end in CR alone"]),
    ("flatplank-cr-only-line-ends", cr_only(FP), ROOT_CMD, FP,
     [":1: ", "its lines end in CR alone"]),
    ("tdx-cr-only-line-ends", cr_only(TDX), ROOT_CMD, TDX,
     [":1: ", "its lines end in CR alone"]),
    ("run-file-nul-byte", edit("tyre.toml", f'"{TR}"', '"trailer/a\\u0000b.csv"'), ROOT_CMD,
     "tyre.toml", ["runs[2].file: ", "holds a NUL byte"]),
    ("fit-run-file-nul-byte", edit("tyre.toml", f'"{TR}"', '"trailer/a\\u0000b.csv"'), FIT,
     "tyre.toml", ["runs[2].file: ", "holds a NUL byte"]),
    # outputs pointed at inputs (issue 44)
    ("eval-output-is-the-points", nothing, ["eval", "{root}/" + TIR, "-i", "{root}/" + PTS,
                                            "-o", "{root}/" + PTS], PTS,
     ["--output: ", "is the input file"]),
    ("eval-output-is-the-tir", nothing, ["eval", "{root}/" + TIR, "-i", "{root}/" + PTS,
                                         "-o", "{root}/" + TIR], TIR,
     ["--output: ", "is the input file"]),
    ("fit-out-is-the-folder", nothing, ["fit", "{root}", "--out", "{root}"], "",
     ["--out: ", "is inside the input folder"]),
    ("fit-reports-inside-the-folder", nothing, ["fit", "{root}", "--out", "{out}/f",
                                                "--reports", "{root}/trailer"], "trailer",
     ["--reports: ", "is inside the input folder"]),
    # HDF5
    ("hdf5-zero-samples", h5_rewrite(h5_empty), ROOT_CMD, H5,
     ["cornering_p220: ", "0 samples"]),
    ("hdf5-dangling-link", h5_rewrite(h5_dangling), ROOT_CMD, H5,
     ["cornering_p220/FYW: ", "dangling link"]),
    ("hdf5-overflow-after-kpa", h5_rewrite(h5_overflow), ROOT_CMD, H5,
     ["INFLPRES: ", "not finite in SI"]),
    ("hdf5-truncated", truncate(H5, 3000), ROOT_CMD, H5, ["HDF5"]),
    ("hdf5-signature-only", truncate(H5, 8), ROOT_CMD, H5, ["HDF5"]),
    ("hdf5-corrupt-metadata", overwrite(H5, 2000), ROOT_CMD, H5, ["corrupt HDF5 file"]),
    # TYDEX
    ("tdx-factor-overflow", edit(TDX, "bar       1 0 0", "bar       1e308 0 0"), ROOT_CMD,
     TDX, [":", "INFLPRES: ", "is not finite"]),
    ("tdx-constant-nan", tdx_constant_nan, ROOT_CMD, TDX,
     ["INFLPRES: ", "constant 'nan' is not a finite number"]),
    ("tdx-overflow-after-unit", edit(TDX, "km/h      1 0 0", "km/h      1e307 0 0"), ROOT_CMD,
     TDX, ["LONGVEL: "]),
    ("tdx-binary-in-data", edit(TDX, b"**MEASURDATA\n", b"**MEASURDATA\n\xff"), ROOT_CMD,
     TDX, [":21: ", "cannot parse the **MEASURDATA section"]),
    # TTC files (convert reads one alone)
    ("ttc-mat-overflow-after-psi", ttc_mat_overflow,
     ["convert", "{root}/extra/session.mat", "{out}/c.h5"], "extra/session.mat",
     ["P: ", "1e+308 psi", "not finite in SI"]),
    ("ttc-mat-unknown-type-code", ttc_mat_bad_type,
     ["convert", "{root}/extra/session.mat", "{out}/c.h5"], "extra/session.mat",
     ["truncated or corrupt .mat file", "array data of type 200"]),
    ("ttc-mat-logical-camber", ttc_mat_logical("IA"),
     ["convert", "{root}/extra/session.mat", "{out}/c.h5"], "extra/session.mat",
     ["IA: ", "a MATLAB logical (true/false) array, not a measurement"]),
    ("ttc-mat73-logical-load", ttc_mat_logical("FZ", "7.3"),
     ["convert", "{root}/extra/session.mat", "{out}/c.h5"], "extra/session.mat",
     ["FZ: ", "a MATLAB logical (true/false) array, not a measurement"]),
    # characteristic tables
    ("table-cell-over-field-limit", edit(TAB, "251700.0", BIG), ROOT_CMD, TAB,
     [":2: ", "cannot parse CSV: field larger than field limit"]),
    ("table-1e308-n-per-mm", edit(TAB, "145.2,N/mm", "1e308,N/mm"), ROOT_CMD, TAB,
     [":3: value: ", "not finite after the unit conversion"]),
    ("table-value-1e300", edit(TAB, "251700.0", "1e300"), ROOT_CMD, TAB,
     [":2: value: ", "not physical"]),
    ("table-multiline-quoted", edit(TAB, "CFy,", '"CF\ny",'), ROOT_CMD, TAB,
     [":3: quantity: ", "unknown quantity 'CF\\ny'"]),
    ("table-not-utf8", raw_line(TAB, 4, b"sigma_y,2.5,5000,385.0,\xe9m"), ROOT_CMD, TAB,
     [":4: ", "not UTF-8 text"]),
    ("table-pressure-1e6-bar", edit(TAB, "CFz,2.5,", "CFz,1e6,"), ROOT_CMD, TAB,
     [":2: pi_bar: ", "not physical"]),
    ("table-load-2e6", edit(TAB, "CFz,2.5,5000,", "CFz,2.5,2e6,"), ROOT_CMD, TAB,
     [":2: Fz_N: ", "not physical"]),
    ("single-table-all-loads-zero", nothing, ["check", "{root}/characteristics.csv"],
     "characteristics.csv", ["no nominal load given and none in the table"]),
    ("single-table-negative-pressure", nothing,
     ["check", "{root}/" + TAB, "--nominal-pressure", "-1"], TAB,
     ["--nominal-pressure: ", "not physical"]),
    ("single-table-zero-load", nothing, ["check", "{root}/" + TAB, "--nominal-load", "0"], TAB,
     ["--nominal-load: ", "must be > 0"]),
    ("fit-single-table-negative-pressure", nothing,
     ["fit", "{root}/" + TAB, "--nominal-pressure", "-1", "--out", "{out}/f", "--reports",
      "{out}/r"], TAB, ["--nominal-pressure: ", "not physical"]),
    ("fit-unsafe-id", edit("tyre.toml", '"225-50R17-test"', '"../../escaped_by_id"'),
     ["fit", "{root}", "--out", "{out}/f", "--reports", "{out}/r"], "tyre.toml",
     ["tyre.id: ", "not a safe file name"]),
    # .tir keys the model divides by, and .tir files that are not files
    ("tir-fnomin-zero", tir_key("FNOMIN", "0"), EVAL, TIR, ["FNOMIN: ", "must not be 0"]),
    ("tir-unloaded-radius-zero", tir_key("UNLOADED_RADIUS", "0"), EVAL, TIR,
     ["UNLOADED_RADIUS: ", "must not be 0"]),
    ("tir-nompres-zero", tir_key("NOMPRES", "0"), EVAL, TIR, ["NOMPRES: ", "must not be 0"]),
    ("tir-longvl-zero", tir_key("LONGVL", "0.0"), EVAL, TIR, ["LONGVL: ", "must not be 0"]),
    ("tir-fnomin-negative", tir_key("FNOMIN", "-4000"), EVAL, TIR,
     ["FNOMIN: ", "not physical"]),
    ("tir-fnomin-1e300", tir_key("FNOMIN", "1e300"), EVAL, TIR, ["FNOMIN: ", "not physical"]),
    ("tir-radius-100", tir_key("UNLOADED_RADIUS", "100"), EVAL, TIR,
     ["UNLOADED_RADIUS: ", "not physical"]),
    ("tir-fzmin-above-fzmax", tir_key("FZMIN", "20000"), EVAL, TIR,
     ["FZMIN: ", "FZMIN = 20000 > FZMAX", "no operating point lies in the range"]),
    ("tir-cammin-above-cammax", tir_key("CAMMIN", "0.5"), EVAL, TIR,
     ["CAMMIN: ", "CAMMIN = 0.5 > CAMMAX"]),
    ("tir-fifo", fifo(TIR), EVAL, TIR, ["is a named pipe (FIFO)"]),
    ("tir-no-model-header", edit(TIR, "[MODEL]\n", ""), EVAL, TIR,
     [":18: FITTYP: ", "no [MODEL] section header"]),
    ("tir-no-vertical-header", edit(TIR, "[VERTICAL]\n", ""), EVAL, TIR,
     [":52: FNOMIN: ", "no [VERTICAL] section header"]),
    ("tir-not-utf8", raw_line(TIR, 53, b"FNOMIN = 50\xff00"), EVAL, TIR,
     [":53: FNOMIN: ", "non-UTF-8 byte 0xFF"]),
    ("tir-dev-null", nothing, ["eval", "/dev/null", "-i", "{root}/" + PTS, "-o", "{out}/e.csv"],
     "/dev/null", ["is a device"]),
    # operating points
    ("points-fifo", fifo(PTS), EVAL, PTS, ["is a named pipe (FIFO)"]),
    ("points-dev-null", nothing, ["eval", "{root}/" + TIR, "-i", "/dev/null", "-o",
                                  "{out}/e.csv"], "/dev/null", ["is a device"]),
    ("points-duplicate-after-strip", edit(PTS, "Vx,p\n", "Vx,p, p\n"), EVAL, PTS,
     [":1: p: duplicate column"]),
    ("points-negative-pressure", edit(PTS, "16.7,250000\n", "16.7,-1\n"), EVAL, PTS,
     [":2: p: ", "not physical"]),
    ("points-pressure-1e300", edit(PTS, "16.7,250000\n", "16.7,1e300\n"), EVAL, PTS,
     [":2: p: ", "not physical"]),
    ("points-alpha-100rad", edit(PTS, "5000,0.0,0.05,", "5000,0.0,100,"), EVAL, PTS,
     [":2: alpha: ", "not physical"]),
    ("points-speed-1e4", edit(PTS, "0.0,16.7,250000\n", "0.0,1e4,250000\n"), EVAL, PTS,
     [":2: Vx: ", "not physical"]),
    ("points-blank-lines-then-bad-cell", edit(PTS, "250000\n4000,0.02,", "250000\n\n\n4000,x,"),
     EVAL, PTS, [":5: kappa: ", "not a number: 'x'"]),
    ("points-blank-line-then-implausible", edit(PTS, "250000\n4000,0.02,0.0,0.0,16.7,",
                                                "250000\n\n4000,0.02,0.0,0.0,1e4,"),
     EVAL, PTS, [":4: Vx: ", "not physical"]),
    ("points-not-utf8", raw_line(PTS, 3, b"4000,0.02,0.0,0.0,16.7,\xff"), EVAL, PTS,
     [":3: ", "not UTF-8 text"]),
    ("points-multiline-quoted", edit(PTS, "16.7,250000\n4000", '16.7,"25\n0000"\n4000'), EVAL,
     PTS, [":2: p: ", "not a number: '25\\n0000'"]),
    ("points-huge-number", edit(PTS, "16.7,250000\n", "16.7,1" + "0" * 400 + "\n"), EVAL, PTS,
     [":2: p: "]),
    # convert: the file alone (units from its header)
    ("convert-fifo", fifo(TR), ["convert", "{root}/" + TR, "{out}/c.h5"], TR,
     ["is a named pipe (FIFO)"]),
    ("convert-overflow-after-kpa", both(
        raw_line(TR, 1, b"RUNTIME,LONGVEL,WHROTSPD,SLIPANGL [deg],LONGSLIP,INCLANGL,"
                        b"INFLPRES [kPa],FX,FYW,FZW,MXW,MYW,MZW"),
        cell(TR, 5, "INFLPRES [kPa]", "1e308")), ["convert", "{root}/" + TR, "{out}/c.h5"],
     TR, [":5: INFLPRES: ", "not finite in SI"]),
    ("convert-cell-over-field-limit", cell(TR, 5, "FYW", BIG),
     ["convert", "{root}/" + TR, "{out}/c.h5"], TR, [":5: ", "field larger than field limit"]),
]


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return write_good_folder(tmp_path_factory.mktemp("good") / "folder")


def test_corpus_is_large_enough():
    assert len(CASES) >= 60 and len({c[0] for c in CASES}) == len(CASES)


@pytest.mark.parametrize("name,mutate,args,file,fragments", CASES, ids=[c[0] for c in CASES])
def test_hostile_input(good, tmp_path, name, mutate, args, file, fragments):
    root = tmp_path / "folder"
    shutil.copytree(good, root, symlinks=True)
    out = tmp_path / "out"
    out.mkdir()
    mutate(root)
    before = sorted(os.listdir(tmp_path))
    argv = [a.format(root=root, out=out) for a in args]
    result = runner.invoke(app, argv)
    assert result.exit_code == 2, (result.exit_code, result.output)
    assert "Traceback" not in result.output and result.exception is None or \
        isinstance(result.exception, SystemExit), result.exception
    lines = [x for x in result.stderr.splitlines()
             if not x.startswith("warning: ") and " problem(s)" not in x]
    assert len(lines) == 1, result.stderr  # one error, on one line
    line = lines[0].removeprefix("error: ")
    where = file if file.startswith("/") else f"{root}/{file}" if file else str(root)
    assert line.startswith(where), (where, line)
    rest = line[len(where):]
    position = 0
    for fragment in fragments:
        found = rest.find(fragment, position)
        assert found >= 0, (fragment, line)
        position = found + len(fragment)
    assert len(line) < 600
    assert sorted(os.listdir(tmp_path)) == before  # nothing written next to the folder
    assert not any(out.iterdir())  # and no output


def test_hdf5_that_makes_the_library_loop(tmp_path, monkeypatch):
    """One byte changed in an HDF5 trailer file (found by the hypothesis
    trials of the HDF5 reader) makes the HDF5 library loop for good on reading it: the
    metadata is read in a child first, which is stopped after PROBE_SECONDS."""
    monkeypatch.setattr(hdf5_probe, "PROBE_SECONDS", 2.0)
    path = write_hdf5(tmp_path / "run.h5", [RawRun("r", trailer_channels(),
                                                   {"SLIPANGL": "rad"})])
    data = bytearray(path.read_bytes())
    assert data[2952] == 8  # the byte the trial changed (h5py writes these bytes every time)
    data[2952] = 9
    path.write_bytes(bytes(data))
    problems = Problems()
    assert read_channels(path, problems=problems) is None
    assert [str(p) for p in problems.finish()] == [
        f"{path}: corrupt HDF5 file (reading its metadata did not finish in 2 s (the HDF5 "
        "library loops on it))"]
