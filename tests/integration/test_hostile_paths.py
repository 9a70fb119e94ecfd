"""No command writes outside ``--out``/``--reports``, whatever the tyre id or run path says.

The tyre id names the fit directory, the .tir and the report, so it must be a safe file name;
a run's ``file`` must resolve inside the measurement folder (no ``..``, no absolute path, no
symbolic link pointing out, no link loop). Both are ``mfid check`` errors, and ``fit`` and
``discover`` refuse them before writing anything (issue 15, acceptance 2).
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.names import inside, name_problem, safe_name
from tests.measurement_cases import write_good_folder

runner = CliRunner()
TR = "trailer/cornering_p250.csv"
BAD_IDS = ["../../escaped_by_id", "", ".", "..", "/tmp/abs_id", "a/b", "a\\b", "x y",
           "..\\..\\win", "id\x00nul", "tab\tid", "x" * 300]


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return write_good_folder(tmp_path_factory.mktemp("good") / "folder")


def _tree(root: Path) -> set[str]:
    out = set()
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            out.add(os.path.relpath(os.path.join(dirpath, name), root))
    return out


def _commands(folder: Path, base: Path) -> list[list[str]]:
    return [["check", str(folder)],
            ["fit", str(folder), "--out", str(base / "out"), "--reports", str(base / "reps"),
             "--only", "CFz"],
            ["discover", str(folder), "--out", str(base / "out" / "disc"), "--only", "CFz"]]


def _run_all(folder: Path, base: Path, expected: str) -> None:
    before = _tree(base)
    for args in _commands(folder, base):
        result = runner.invoke(app, args)
        assert result.exit_code == 2, (args, result.output)
        assert "Traceback" not in result.output
        assert any(all(e in line for e in expected.split("|"))
                   for line in result.stderr.splitlines()), \
            (args, result.stderr)
        # nothing at all was written: not outside --out/--reports, not inside either
        assert _tree(base) == before, (args, _tree(base) - before)


@pytest.mark.parametrize("tyre_id", BAD_IDS, ids=range(len(BAD_IDS)))
def test_unsafe_tyre_id_is_refused(good, tmp_path, tyre_id):
    base = tmp_path / "a" / "b"  # '../../x' from out would land in tmp_path
    folder = base / "folder"
    shutil.copytree(good, folder)
    text = (folder / "tyre.toml").read_text()
    escaped = tyre_id.replace("\\", "\\\\").replace("\x00", "\\u0000").replace("\t", "\\t")
    (folder / "tyre.toml").write_text(text.replace('id = "225-50R17-test"',
                                                   f'id = "{escaped}"'))
    before = _tree(tmp_path)
    _run_all(folder, base, "tyre.id: ")
    assert _tree(tmp_path) == before


def _outside_csv(tmp_path: Path, good: Path) -> Path:
    target = tmp_path / "outside.csv"
    shutil.copy(good / TR, target)
    return target


@pytest.mark.parametrize("how", ["dotdot", "absolute", "symlink-out", "symlink-loop",
                                 "symlink-dir-out", "dotdot-inside-then-out"])
def test_run_file_outside_the_folder_is_refused(good, tmp_path, how):
    base = tmp_path / "base"
    folder = base / "folder"
    shutil.copytree(good, folder)
    outside = _outside_csv(base, good)
    toml = folder / "tyre.toml"
    name = {"dotdot": "../outside.csv", "absolute": str(outside),
            "symlink-out": "trailer/link.csv", "symlink-loop": "trailer/loop.csv",
            "symlink-dir-out": "up/outside.csv",
            "dotdot-inside-then-out": "trailer/../../outside.csv"}[how]
    if how == "symlink-out":
        (folder / "trailer" / "link.csv").symlink_to(outside)
    elif how == "symlink-loop":
        (folder / "trailer" / "loop.csv").symlink_to(folder / "trailer" / "loop.csv")
    elif how == "symlink-dir-out":
        (folder / "up").symlink_to(base, target_is_directory=True)
    toml.write_text(toml.read_text().replace(f'file = "{TR}"', f'file = "{name}"'))
    message = {"absolute": "an absolute path is not allowed",
               "symlink-loop": "cannot resolve"}.get(how, "leads outside the measurement folder")
    _run_all(folder, base, f"runs[2].file: |{message}")


def test_a_symlink_inside_the_folder_is_followed(good, tmp_path):
    folder = tmp_path / "folder"
    shutil.copytree(good, folder)
    (folder / "trailer" / "same.csv").symlink_to(folder / TR)
    toml = folder / "tyre.toml"
    toml.write_text(toml.read_text().replace(f'file = "{TR}"', 'file = "trailer/same.csv"'))
    result = runner.invoke(app, ["check", str(folder)])
    assert result.exit_code == 0, result.output


def test_names():
    assert name_problem("225-50R17_v2.1") is None
    assert name_problem("Straßenreifen-été") is None  # letters of any script are letters
    for bad in BAD_IDS:
        assert name_problem(bad), bad
    assert safe_name("../a//b c") == "a-b-c" and safe_name("..") == ""
    assert inside(Path("/x/y"), "../z")[0] is None
    assert inside(Path("/x/y"), "a/../b")[0] == Path("/x/y/b")
