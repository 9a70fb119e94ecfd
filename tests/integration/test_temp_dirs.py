"""Temporary folders of the folder writers (simulate, import) are removed on success, on an
error and on SIGTERM, and a folder being replaced is never lost (issue 44).

A folder is built in ``.<name>.<pid>.<random>.tmp`` next to its target and renamed into place
(identify.core.atomic.temp_dir, replace_dir); the folder it replaces is moved aside and put back
if the rename fails. A temporary folder left by a process killed outright is removed by the
next write of the same target.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from identify.cli.entry import MESSAGE, Interrupted
from identify.core import atomic
from identify.core.atomic import replace_dir, temp_dir
from identify.workflows import import_session
from tests.measurement_cases import dead_pid

MFID = shutil.which("mfid", path=str(Path(sys.executable).parent))


def _hidden(folder: Path) -> list[str]:
    """Entries of ``folder`` whose name starts with a dot (the temporaries)."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def _folder(path: Path, text: str) -> Path:
    path.mkdir(parents=True)
    (path / "sub").mkdir()
    (path / "sub" / "f.txt").write_text(text)
    return path



def test_replace_dir_puts_the_new_folder_in_place_and_removes_the_old(tmp_path):
    target = _folder(tmp_path / "out", "old")
    new = temp_dir(target)
    (new / "f.txt").write_text("new")
    assert replace_dir(new, target) == target
    assert (target / "f.txt").read_text() == "new" and not (target / "sub").exists()
    assert _hidden(tmp_path) == []


def test_a_failed_rename_puts_the_old_folder_back(tmp_path):
    target = _folder(tmp_path / "out", "old")
    with pytest.raises(FileNotFoundError):
        replace_dir(tmp_path / ".absent", target)
    assert (target / "sub" / "f.txt").read_text() == "old"
    assert _hidden(tmp_path) == []


def test_sigterm_between_the_renames_puts_the_old_folder_back(tmp_path, monkeypatch):
    """The interrupt identify.cli.entry raises for SIGTERM, arriving as the new folder is
    renamed in: the old folder is back, no temporary is left."""
    target = _folder(tmp_path / "out", "old")
    new = temp_dir(target)
    rename, calls = os.rename, []

    def interrupted_second(src, dst):
        calls.append(src)
        if len(calls) == 2:
            raise Interrupted(signal.SIGTERM)
        rename(src, dst)

    monkeypatch.setattr(atomic.os, "rename", interrupted_second)
    with pytest.raises(Interrupted):
        replace_dir(new, target)
    monkeypatch.undo()
    shutil.rmtree(new)  # the caller's part (its except BaseException)
    assert (target / "sub" / "f.txt").read_text() == "old"
    assert _hidden(tmp_path) == []


def test_a_killed_writers_temporary_folder_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "out"
    dead = _folder(tmp_path / f".out.{dead_pid()}.abcd1234.tmp", "partial")
    alive = _folder(tmp_path / f".out.{os.getpid()}.abcd1234.tmp", "being written")
    other = _folder(tmp_path / f".other.{dead_pid()}.abcd1234.tmp", "another target's")
    new = temp_dir(target)
    assert not dead.exists() and alive.exists() and other.exists()
    assert new.name.startswith(f".out.{os.getpid()}.") and new.name.endswith(".tmp")


@pytest.mark.parametrize("fate", ["success", "error", "sigterm"])
def test_import_leaves_no_temporary_folder(tmp_path, monkeypatch, fate):
    """import's folder writer: complete on success; on an error or SIGTERM while the files
    are copied, the earlier import is kept whole and no temporary is left."""
    source = tmp_path / "in" / "run.csv"
    source.parent.mkdir()
    source.write_text("RUNTIME\n0\n")
    out = _folder(tmp_path / "work" / "imported", "earlier import")
    if fate != "success":
        def failing_copy(src, dst):
            if fate == "error":
                raise OSError(28, "No space left on device")
            raise Interrupted(signal.SIGTERM)
        monkeypatch.setattr(import_session.shutil, "copyfile", failing_copy)
    try:
        import_session._write(out, "id = 'x'\n", {str(source): "trailer/run.csv"}, True)
    except (OSError, Interrupted):
        assert fate != "success"
        assert (out / "sub" / "f.txt").read_text() == "earlier import"
    else:
        assert fate == "success"
        assert (out / "trailer" / "run.csv").read_text() == "RUNTIME\n0\n"
    assert _hidden(out.parent) == []


@pytest.mark.skipif(MFID is None, reason="the mfid console script is not installed")
def test_sigterm_during_simulate_removes_its_temporary_folder(tmp_path):
    """A real ``mfid simulate --format ttc`` terminated while it writes into its temporary
    folder: exit 143, the one-line message, nothing left next to the target."""
    out = tmp_path / "session"
    proc = subprocess.Popen([MFID, "simulate", "default", str(out), "--format", "ttc"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=tmp_path)
    deadline = time.monotonic() + 120
    while not _hidden(tmp_path) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None, "simulate finished before its temporary folder was seen"
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM, stderr
    assert stderr.splitlines()[-1] == MESSAGE and "Traceback" not in stderr
    assert _hidden(tmp_path) == [] and not out.exists()
