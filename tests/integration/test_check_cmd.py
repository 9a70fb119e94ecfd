"""``mfid check`` on a corpus of bad folders, ``mfid convert``, and no command modifies a folder.

The corpus is generated from one good folder (tests/measurement_cases.py): each case applies
one mutation and names the line ``mfid check`` must print (file[:line]: key: message, the
folder path in front). ``load_folder`` must fail on the same problem (the first one listed).
"""
from __future__ import annotations

import hashlib
import os
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.errors import InputError
from identify.io.folder import load_folder
from identify.io.hdf5.channel_files import RawRun, write_hdf5
from identify.io.trailer.files import read_channels
from tests.measurement_cases import (
    FP,
    H5,
    TDX,
    TR,
    edit,
    rewrite_lines,
    set_cell,
    trailer_channels,
    write_good_folder,
)

runner = CliRunner()


# ------------------------------------------------------------------ mutation helpers

def edit_line(rel: str, line: int, fn):
    def change(lines: list[str]) -> list[str]:
        lines[line - 1] = fn(lines[line - 1])
        return lines
    return rewrite_lines(rel, change)


def drop_column(rel: str, column: str):
    def change(lines: list[str]) -> list[str]:
        rows = [r.split(",") for r in lines]
        col = rows[0].index(column)
        return [",".join(r[:col] + r[col + 1:]) for r in rows]
    return rewrite_lines(rel, change)


def write(rel: str, data: bytes | str):
    def apply(root: Path) -> None:
        (root / rel).write_bytes(data if isinstance(data, bytes) else data.encode())
    return apply


def h5_set(name: str, index: int, value: float):
    def apply(root: Path) -> None:
        with h5py.File(root / H5, "r+") as fh:
            fh[f"cornering_p220/{name}"][index] = value
    return apply


def h5_two_groups(root: Path) -> None:
    write_hdf5(root / H5, [RawRun("left", trailer_channels()), RawRun("right", trailer_channels())])


def keep_lines(rel: str, count: int):
    return rewrite_lines(rel, lambda lines: lines[:count])


def remove(rel: str):
    def apply(root: Path) -> None:
        path = root / rel
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    return apply


def make_dir(rel: str):
    def apply(root: Path) -> None:
        (root / rel).unlink()
        (root / rel).mkdir()
    return apply


def european(rel: str):
    """The CSV as a European spreadsheet exports it: semicolons, decimal commas."""
    def apply(root: Path) -> None:
        text = (root / rel).read_text()
        (root / rel).write_text(text.replace(",", ";").replace(".", ","))
    return apply


def rig_export(rel: str, line: int, column: str, value: str):
    """Cell ``column`` of ``line`` set, then the CSV written as some rigs do: a byte-order
    mark, CRLF line ends, a blank line after the header and one after line 4 (a cell's line
    moves down by 1, or by 2 below line 4)."""
    def apply(root: Path) -> None:
        set_cell(rel, line, column, value)(root)
        lines = (root / rel).read_text().splitlines()
        lines[1:1] = [""]
        lines[5:5] = [""]
        (root / rel).write_bytes(("\ufeff" + "\r\n".join(lines) + "\r\n").encode())
    return apply


# ------------------------------------------------------------------ the corpus
# (id, mutation, expected line; "..." at the end means "starts with")
CASES = [
    # malformed CSV
    ("csv-ragged-row", edit(TR, "\n", "\n1.0,2.0,3.0\n"),
     f"{TR}:2: ragged row: 3 fields, the header has 13"),
    ("csv-non-numeric", set_cell(TR, 5, "FYW", "abc"), f"{TR}:5: FYW: not a number: 'abc'"),
    ("csv-empty-file", write(TR, ""),
     f"{TR}:1: empty file: expected a header line with the column names"),
    ("csv-header-only", keep_lines(TR, 1),
     f"{TR}:1: no data rows below the header"),
    ("csv-binary", write(TR, b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe"),
     f"{TR}:1: not a UTF-8 text file"),
    ("csv-semicolons-decimal-commas", european(TR),
     f"{TR}:1: the header is one column with semicolons in it: expected values separated by "
     "commas, with a decimal point"),
    ("csv-duplicate-column", edit_line(TR, 1, lambda s: s.replace("FX,", "FYW,")),
     f"{TR}:1: FYW: duplicate column"),
    ("flatplank-ragged", edit_line(FP, 4, lambda s: s + ",7"),
     f"{FP}:4: ragged row: 14 fields, the header has 13"),
    # NaN / inf
    ("flatplank-inf", set_cell(FP, 4, "Gy", "-inf"), f"{FP}:4: Gy: -inf is not allowed (NaN/inf)"),
    # missing required channels
    ("trailer-missing-channel", drop_column(TR, "MZW"), f"{TR}: MZW: missing required channel"),
    ("flatplank-missing-column", drop_column(FP, "loaded_radius"),
     f"{FP}:1: loaded_radius: missing required column (found: ..."),
    ("hdf5-two-groups-no-match", h5_two_groups,
     f"{H5}: cornering_p220: no group 'cornering_p220' (groups: left, right)"),
    # unknown units or axis names
    ("manifest-unknown-unit", edit("tyre.toml", 'SLIPANGL = "deg"', 'SLIPANGL = "degs"'),
     "tyre.toml: runs[2].units.SLIPANGL: unknown unit 'degs'"),
    ("header-unknown-unit", edit_line(TR, 1, lambda s: s.replace("FZW", "FZW [kgs]")),
     f"{TR}: FZW: unknown unit 'kgs'"),
    ("tdx-unknown-unit", edit(TDX, "km/h      ", "kmph/h    "),
     f"{TDX}: LONGVEL: unknown unit 'kmph/h'"),
    ("unit-wrong-dimension", edit("tyre.toml", 'SLIPANGL = "deg"', 'SLIPANGL = "kPa"'),
     f"{TR}: SLIPANGL: unit 'kPa' is a pressure unit, expected an angle unit such as 'rad'"),
    ("unit-conflict", edit_line(TR, 1, lambda s: s.replace("SLIPANGL", "SLIPANGL [rad]")),
     f"{TR}: SLIPANGL: unit conflict: the manifest says 'deg', the file says 'rad'"),
    ("unit-for-absent-channel", edit("tyre.toml", 'SLIPANGL = "deg"', 'SLIPANGLE = "deg"'),
     f"{TR}: SLIPANGLE: the manifest gives a unit for a channel that is not in the file"),
    ("unknown-axes", edit("tyre.toml", 'axes = "ISO-W"', 'axes = "ISO"'),
     "tyre.toml: runs[2].axes: unknown axis system 'ISO' (expected one of: ISO-W, SAE, TYDEX-C)"),
    ("c-channel-in-iso-run", edit_line(TR, 1, lambda s: s.replace("FYW", "FYC")),
     f"{TR}: FYC: a wheel-centre (C-axis) channel, but the run's axes are 'ISO-W' (use TYDEX-C)"),
    # non-monotonic time
    ("csv-time-back", set_cell(TR, 12, "RUNTIME", "0.1"),
     f"{TR}:12: RUNTIME: time is not increasing: 0.1 after 0.9 (1 such sample(s))"),
    ("flatplank-time-repeats", set_cell(FP, 3, "time", "0.0"),
     f"{FP}:3: time: time is not increasing: 0.0 after 0.0 (1 such sample(s))"),
    ("flatplank-time-repeats-rig-export", rig_export(FP, 3, "time", "0.0"),
     f"{FP}:4: time: time is not increasing: 0.0 after 0.0 (1 such sample(s))"),
    ("hdf5-time-back", h5_set("RUNTIME", 5, 0.0),
     f"{H5}: RUNTIME: time is not increasing at sample 5: 0.0 after 0.4 (1 such sample(s))"),
    # manifest keys
    ("duplicate-run-id", edit("tyre.toml", 'id = "cornering_p220"', 'id = "cornering_p250"'),
     "tyre.toml: runs[3].id: duplicate run id 'cornering_p250' (also runs[2])"),
    ("manifest-missing-key", edit("tyre.toml", "nominal_load_N = 5000\n", ""),
     "tyre.toml: tyre.nominal_load_N: missing required key (number)"),
    ("manifest-wrong-type", edit("tyre.toml", "unloaded_radius_m = 0.3205",
                                 'unloaded_radius_m = "0.3205"'),
     "tyre.toml: tyre.unloaded_radius_m: expected a number, got a string ('0.3205')"),
    ("manifest-unknown-key", edit("tyre.toml", "nominal_pressure_Pa", "nominal_presure_Pa"),
     "tyre.toml: tyre.nominal_presure_Pa: unknown key (did you mean 'nominal_pressure_Pa'?)"),
    ("manifest-bad-condition", edit("tyre.toml", "pressure_Pa = 220000", "pressure_Pa = -1"),
     "tyre.toml: runs[3].conditions.pressure_Pa: must be positive, got -1.0"),
    ("manifest-unknown-kind", edit("tyre.toml", 'kind = "flatplank"', 'kind = "flatplanck"'),
     "tyre.toml: runs[0].kind: unknown kind 'flatplanck' (expected one of: trailer, flatplank, "
     "characteristics)"),
    ("manifest-unknown-test", edit("tyre.toml", 'test = "parking"', 'test = "parked"'),
     "tyre.toml: runs[0].test: unknown flatplank test 'parked' (expected one of: ..."),
    ("manifest-no-rig", edit("tyre.toml", "[rig]\nhub_a_m = 0.08\nhub_b_m = 0.05\n", ""),
     "tyre.toml: rig: missing table [rig] (hub_a_m, hub_b_m): needed for the flatplank run "
     "runs[0]"),
    ("manifest-syntax", edit("tyre.toml", 'id = "225-50R17-test"', 'id = 225-50R17-test'),
     "tyre.toml:2: invalid TOML: ..."),
    ("manifest-absent", remove("tyre.toml"), "tyre.toml: no tyre.toml in the folder"),
    # files named in the manifest that do not exist
    ("file-missing", remove(FP),
     f"tyre.toml: runs[0].file: file not found: {{root}}/{FP}"),
    ("file-is-directory", make_dir(H5),
     f"tyre.toml: runs[3].file: is a directory, expected a file: {{root}}/{H5}"),
    # pressure or load far from the manifest
    ("trailer-pressure-far", edit("tyre.toml", "pressure_Pa = 250000, load_N = 5000 }",
                                  "pressure_Pa = 350000, load_N = 5000 }"),
     f"{TR}: INFLPRES: median pressure 250000 Pa is more than 15% from the declared 350000 Pa"),
    ("trailer-load-far", edit("tyre.toml", "pressure_Pa = 220000, load_N = 5000",
                              "pressure_Pa = 220000, load_N = 3000"),
     f"{H5}: FZW: median load Fz 50..."),
    ("sae-read-as-iso", edit("tyre.toml", 'axes = "SAE"', 'axes = "ISO-W"'),
     f"{TDX}: FZW: median load Fz -49..."),
    ("flatplank-load-far", edit("tyre.toml", "pressure_Pa = 250000, load_N = 5000, "
                                "start_position = 1 }", "pressure_Pa = 250000, load_N = 7000, "
                                "start_position = 1 }"),
     f"{FP}: Fz: median contact load Fz 5000.2 N is more than 15% from the declared 7000 N"),
    # characteristic tables
    ("characteristics-quantity", edit("tables/thesis.csv", "CFy,", "CFyy,"),
     "tables/thesis.csv:3: quantity: unknown quantity 'CFyy' (expected one of: ..."),
    ("characteristics-unit", edit("tables/thesis.csv", "385.0,mm", "385.0,mmm"),
     "tables/thesis.csv:4: unit: unknown unit 'mmm' for sigma_y"),
    ("root-characteristics-mode", edit("characteristics.csv", "Hz,z", "Hz,q"),
     "characteristics.csv:2: mode: unknown mode 'q' (expected one of: x, y, z, theta, gamma, psi)"),
    ("tdx-ragged", edit_line(TDX, 24, lambda s: s.rsplit(" ", 2)[0]),
     f"{TDX}:24: ragged row: 11 values, 13 channels"),
]


#: Quirks of usable trailer data: ``mfid check`` passes (exit 0) and prints the warning.
WARNING_CASES = [
    ("csv-nan", set_cell(TR, 8, "FZW", "nan"),
     f"{TR}:8: FZW: NaN/inf values in 1 stretch(es): FZW 1 (1 of 41 samples); set NaN"),
    ("csv-bom-crlf-blank-lines", rig_export(TR, 8, "FZW", "nan"),
     f"{TR}:10: FZW: NaN/inf values in 1 stretch(es): FZW 1 (1 of 41 samples); set NaN"),
    ("csv-empty-cell", set_cell(TR, 7, "FX", ""),
     f"{TR}:7: FX: NaN/inf values in 1 stretch(es): FX 1 (1 of 41 samples); set NaN"),
    ("hdf5-nan", h5_set("FYW", 3, np.nan),
     f"{H5}: FYW: NaN/inf values in 1 stretch(es): FYW 1 (1 of 41 samples); set NaN"),
    ("tdx-nan-time", edit_line(TDX, 23, lambda s: "nan " + s.split(" ", 1)[1]),
     f"{TDX}:23: RUNTIME: time stamp NaN/inf (1 of 41 samples); samples dropped"),
    ("csv-rows-dropped", set_cell(TR, 8, "FZW", "nan"),
     f"{TR}:8: FZW: rows with a missing value in a required channel (1 stretch(es)) "
     "(1 of 41 samples); rows dropped"),
]


def _matches(line: str, expected: str, root: Path) -> bool:
    expected = expected.replace("{root}", str(root))
    full = f"{root}/{expected}"
    return line.startswith(full[:-3]) if expected.endswith("...") else line == full


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return write_good_folder(tmp_path_factory.mktemp("good") / "folder")


def test_corpus_is_large_enough():
    assert len(CASES) >= 25 and len({c[0] for c in CASES}) == len(CASES)


def test_good_folder_is_clean(good):
    result = runner.invoke(app, ["check", str(good)])
    assert result.exit_code == 0, result.stderr
    assert result.stderr == ""
    assert result.stdout.strip() == (
        f"{good}: ok; 225-50R17-test: 7 runs (2 flatplank, 3 trailer, 2 characteristics); "
        "123 trailer samples, 62 flatplank samples, 6 characteristic values")


@pytest.mark.parametrize("name,mutate,expected", CASES, ids=[c[0] for c in CASES])
def test_bad_folder(good, tmp_path, name, mutate, expected):
    root = tmp_path / "folder"
    shutil.copytree(good, root)
    mutate(root)
    result = runner.invoke(app, ["check", str(root)])
    assert result.exit_code == 2
    lines = [x for x in result.stderr.splitlines() if not x.startswith("warning: ")]
    assert lines[-1] == f"{len(lines) - 1} problem(s) in {root}"
    assert any(_matches(line, expected, root) for line in lines[:-1]), "\n".join(lines)
    assert result.stdout == ""
    # every command that reads a folder stops at the first problem check lists
    with pytest.raises(InputError) as err:
        load_folder(root)
    assert str(err.value) == lines[0]


@pytest.mark.parametrize("name,mutate,expected", WARNING_CASES,
                         ids=[c[0] for c in WARNING_CASES])
def test_quirk_is_a_warning(good, tmp_path, name, mutate, expected):
    root = tmp_path / "folder"
    shutil.copytree(good, root)
    mutate(root)
    result = runner.invoke(app, ["check", str(root)])
    assert result.exit_code == 0, result.stderr
    lines = result.stderr.splitlines()
    assert all(x.startswith("warning: ") for x in lines) and lines
    assert any(_matches(x.removeprefix("warning: "), expected, root) for x in lines), lines
    assert result.stdout.startswith(f"{root}: ok with {len(lines)} warning(s) (usable data, "
                                    "cleaned while loading); 225-50R17-test: 7 runs")
    mset = load_folder(root)  # loads; the warnings travel with the set
    assert [f"warning: {w}" for w in mset.warnings] == lines
    assert 120 <= len(mset.trailer) < 123


def test_check_lists_every_problem_at_once(good, tmp_path):
    root = tmp_path / "folder"
    shutil.copytree(good, root)
    for name in ("csv-non-numeric", "flatplank-inf", "hdf5-time-back", "characteristics-quantity",
                 "manifest-unknown-key"):  # a bad [tyre] key does not stop the data checks
        next(c[1] for c in CASES if c[0] == name)(root)
    result = runner.invoke(app, ["check", str(root)])
    assert result.exit_code == 2
    # six lines: the misspelt key is also a missing required key
    assert result.stderr.splitlines()[-1] == f"6 problem(s) in {root}"


def test_check_limits_repeated_problems_per_file(good, tmp_path):
    root = tmp_path / "folder"
    shutil.copytree(good, root)
    lines = (root / TR).read_text().splitlines()
    lines[1:] = [re.sub(r",[^,]*$", ",x", row) for row in lines[1:]]  # MZW all text (41 rows)
    (root / TR).write_text("\n".join(lines) + "\n")
    result = runner.invoke(app, ["check", str(root)])
    out = result.stderr.splitlines()
    assert len([x for x in out if "MZW: not a number: 'x'" in x]) == 10
    assert f"{root}/{TR}: 31 more bad-cell problems not listed" in out


def test_check_missing_folder(tmp_path):
    result = runner.invoke(app, ["check", str(tmp_path / "nope")])
    assert result.exit_code == 2
    assert result.stderr.splitlines()[0] == f"{tmp_path / 'nope'}: no such file or directory"


# ------------------------------------------------------------------ convert

def test_convert_round_trips_exactly(good, tmp_path):
    src = good / TR
    h5, tdx, csv = tmp_path / "a.h5", tmp_path / "a.tdx", tmp_path / "a.csv"
    for a, b in ((src, h5), (h5, tdx), (tdx, csv)):
        result = runner.invoke(app, ["convert", str(a), str(b), "--run", "sweep"])
        assert result.exit_code == 0, result.stderr
        assert result.stdout.startswith(f"wrote {b} (1 run(s), 41 samples)")
    (ref,) = read_channels(src, units={"SLIPANGL": "deg", "INFLPRES": "kPa"})  # as tyre.toml
    for path in (h5, tdx, csv):
        (back,) = read_channels(path)
        assert back.run == ("a" if path == csv else "sweep")  # a CSV has no run name inside
        assert list(back.data) == list(ref.data)
        for key in ref.data:
            np.testing.assert_array_equal(back.data[key], ref.data[key], err_msg=key)
    with h5py.File(h5) as fh:
        assert list(fh) == ["sweep"] and fh["sweep/SLIPANGL"].attrs["units"] == "rad"


@pytest.mark.parametrize("args,message", [
    (["{good}/" + TR, "{tmp}/out.xlsx"], "{tmp}/out.xlsx: unknown output format: expected "
                                          ".csv, .h5, .hdf5 or .tdx"),
    (["{good}/nope.csv", "{tmp}/out.csv"], "error: {good}/nope.csv: file not found"),
])
def test_convert_errors(good, tmp_path, args, message):
    args = [a.format(good=good, tmp=tmp_path) for a in args]
    result = runner.invoke(app, ["convert", *args])
    assert result.exit_code == 2
    assert message.format(good=good, tmp=tmp_path) in result.stderr
    assert not any(p.name.startswith("out") for p in tmp_path.iterdir())


def test_convert_takes_units_from_the_manifest_or_options(good, tmp_path):
    # trailer/cornering_p250.csv holds SLIPANGL in deg and INFLPRES in kPa (tyre.toml says so)
    out = tmp_path / "si.h5"
    assert runner.invoke(app, ["convert", str(good / TR), str(out)]).exit_code == 0
    (si,) = read_channels(out)
    assert si.run == "cornering_p250"
    np.testing.assert_allclose(si.data["INFLPRES"], 250000.0)
    loose = shutil.copy(good / TR, tmp_path / "loose.csv")
    result = runner.invoke(app, ["convert", str(loose), str(tmp_path / "b.h5"), "--unit",
                                 "SLIPANGL=deg", "--unit", "INFLPRES = kPa"])
    assert result.exit_code == 0, result.stderr
    (b,) = read_channels(tmp_path / "b.h5")
    for key in si.data:
        np.testing.assert_array_equal(b.data[key], si.data[key])
    result = runner.invoke(app, ["convert", str(loose), str(tmp_path / "c.h5"), "--unit", "deg"])
    assert result.exit_code == 2
    assert result.stderr.strip() == "error: --unit: expected CHANNEL=UNIT, got 'deg'"


def test_convert_picks_a_run_from_a_multi_run_file(tmp_path):
    src = write_hdf5(tmp_path / "two.h5", [RawRun("left", trailer_channels(n=5)),
                                           RawRun("right", trailer_channels(n=7))])
    result = runner.invoke(app, ["convert", str(src), str(tmp_path / "out.csv")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"error: {tmp_path / 'out.csv'}: a .csv file holds one run, "
                                     "got 2 (left, right): choose one with --run")
    result = runner.invoke(app, ["convert", str(src), str(tmp_path / "out.csv"), "--run", "x"])
    assert result.stderr.strip() == f"error: {src}: x: no group 'x' (groups: left, right)"
    result = runner.invoke(app, ["convert", str(src), str(tmp_path / "out.tdx"), "--run", "right"])
    assert result.exit_code == 0
    assert read_channels(tmp_path / "out.tdx")[0].data["RUNTIME"].size == 7
    result = runner.invoke(app, ["convert", str(src), str(tmp_path / "all.h5")])
    assert result.exit_code == 0 and "2 run(s), 12 samples" in result.stdout


def test_convert_refuses_to_overwrite_its_input(tmp_path):
    src = write_good_folder(tmp_path / "f") / TR
    before = src.read_bytes()
    result = runner.invoke(app, ["convert", str(src), str(src)])
    assert result.exit_code == 2 and "is the input file" in result.stderr
    assert src.read_bytes() == before


# ------------------------------------------------------------------ no command modifies a folder

def _fingerprint(root: Path) -> dict[str, str]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for d in dirnames:
            out[os.path.relpath(os.path.join(dirpath, d), root) + "/"] = "dir"
        for f in filenames:
            path = os.path.join(dirpath, f)
            out[os.path.relpath(path, root)] = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    return out


def test_no_command_modifies_the_folder(tmp_path):
    root = write_good_folder(tmp_path / "folder")
    bad = write_good_folder(tmp_path / "bad")
    set_cell(TR, 5, "FYW", "abc")(bad)
    out = tmp_path / "out"
    out.mkdir()
    commands = [
        ["check", root], ["check", bad], ["check", root / "characteristics.csv"],
        ["convert", root / TR, out / "a.h5"], ["convert", root / H5, out / "b.tdx"],
        ["convert", root / TDX, out / "c.csv"], ["convert", bad / TR, out / "d.h5"],
        ["eval", root / "extra" / "tyre.tir", "--input", root / "extra" / "points.csv",
         "--output", out / "eval.csv"],
    ]
    before = {folder: _fingerprint(folder) for folder in (root, bad)}
    for args in commands:  # each command leaves both folders as they were
        result = runner.invoke(app, [str(a) for a in args])
        assert result.exit_code in (0, 2), (args, result.output)
        for folder in (root, bad):
            assert _fingerprint(folder) == before[folder], (folder, args)
    load_folder(root)
    for folder in (root, bad):
        assert _fingerprint(folder) == before[folder], folder
    assert (out / "eval.csv").is_file() and (out / "a.h5").is_file()
