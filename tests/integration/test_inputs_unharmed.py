"""No command harms an input, whatever its outputs are pointed at (issue 44).

Every command (check, fit, batch, import, convert, report, discover, simulate, eval, extract)
is run with its outputs pointed at its inputs, at links to them (symbolic and hard) and inside
the measurement folder; each must refuse with exit 2 and one line, before any work, and leave
every input byte for byte as it was (SHA-256 of every file before and after) and write
nothing. Outputs of the wrong kind (a --reports that is a regular file, a .tir path that is a
directory) are refused before the fit and leave nothing; a tyre id edited in fit.json cannot
lead a report outside ``reports/``; a killed writer's temporary is removed by the next run.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.atomic import atomic_write_text, remove_stale
from identify.io.output_guard import Inputs, check_file_output, check_folder_output
from tests.measurement_cases import PTS, TR, dead_pid, write_good_folder

runner = CliRunner()
TIR = "extra/tyre.tir"
ID = "225-50R17-test"


def _fingerprint(root: Path) -> dict[str, str]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for d in dirnames:
            out[os.path.relpath(os.path.join(dirpath, d), root) + "/"] = "dir"
        for f in filenames:
            path = Path(dirpath) / f
            out[os.path.relpath(path, root)] = (
                "link:" + os.readlink(path) if path.is_symlink()
                else hashlib.sha256(path.read_bytes()).hexdigest())
    return out


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return write_good_folder(tmp_path_factory.mktemp("good") / "folder")


@pytest.fixture(scope="module")
def fit_dir(good, tmp_path_factory) -> Path:
    """A real fit directory (CFz only: seconds) for the report cases."""
    out = tmp_path_factory.mktemp("fits")
    result = runner.invoke(app, ["fit", str(good), "--only", "CFz", "--out", str(out),
                                 "--no-report"])
    assert result.exit_code == 0, result.output
    return out / ID


def _cases(f: Path, o: Path, fd: Path) -> list[tuple[str, list[str]]]:
    """(name, argv): ``f`` the measurement folder, ``o`` a folder outside it, ``fd`` a fit
    directory; links ``f/extra/pts_link.csv`` (symbolic) and ``o/hard.tir`` (hard) exist."""
    t, p, tr = f / TIR, f / PTS, f / TR
    return [
        ("fit-out-is-folder", ["fit", f, "--out", f, "--only", "CFz"]),
        ("fit-out-inside", ["fit", f, "--out", f / "fits", "--only", "CFz"]),
        ("fit-out-via-toml", ["fit", f / "tyre.toml", "--out", f / "trailer", "--only", "CFz"]),
        ("fit-reports-inside", ["fit", f, "--out", o / "fits", "--reports", f / "trailer",
                                "--only", "CFz"]),
        ("fit-out-parent-named-by-id", ["fit", f, "--out", o / "ids", "--only", "CFz"]),
        ("batch-out-inside", ["batch", f, "--out", f, "--workers", "1", "--no-report"]),
        ("batch-reports-inside", ["batch", f, "--out", o / "b", "--reports", f / "r",
                                  "--workers", "1"]),
        ("import-over-its-file", ["import", tr, "--out", tr]),
        ("import-into-its-folder", ["import", tr, "--out", f / "trailer", "--overwrite"]),
        ("import-into-a-parent", ["import", tr, "--out", f, "--overwrite"]),
        ("convert-onto-itself", ["convert", tr, tr]),
        ("convert-into-folder", ["convert", tr, f / "trailer" / "copy.h5"]),
        ("report-onto-fit-json", ["report", fd, "--output", fd / "fit.json"]),
        ("report-into-fit-dir", ["report", fd, "--output", fd / "report.pdf"]),
        ("discover-out-inside", ["discover", f, "--out", f / "disc", "--only", "CFz"]),
        ("discover-out-is-base", ["discover", f, "--base", t, "--out", t, "--only", "CFz"]),
        ("simulate-over-its-tir", ["simulate", t, f / "extra", "--overwrite", "--grid",
                                   "small"]),
        ("simulate-over-folder", ["simulate", t, f, "--overwrite", "--grid", "small"]),
        ("eval-output-is-points", ["eval", t, "-i", p, "-o", p]),
        ("eval-output-is-tir", ["eval", t, "-i", p, "-o", t]),
        ("eval-output-symlink-to-points", ["eval", t, "-i", p, "-o",
                                           f / "extra" / "pts_link.csv"]),
        ("eval-output-hardlink-to-tir", ["eval", t, "-i", p, "-o", o / "hard.tir"]),
        ("extract-output-inside", ["extract", f, "-o", f / "chars.csv"]),
        ("extract-diagnostics-inside", ["extract", f, "-o", o / "c.csv", "-d",
                                        f / "tables" / "d.json"]),
    ]


CASE_NAMES = [c[0] for c in _cases(Path("f"), Path("o"), Path("d"))]


@pytest.mark.parametrize("name", CASE_NAMES)
def test_outputs_at_inputs_are_refused_and_nothing_changes(good, fit_dir, tmp_path, name):
    f = tmp_path / "folder"
    shutil.copytree(good, f, symlinks=True)
    (f / "extra" / "pts_link.csv").symlink_to(f / PTS)
    o = tmp_path / "out"
    o.mkdir()
    os.link(f / TIR, o / "hard.tir")
    if name == "fit-out-parent-named-by-id":  # OUT/<id> is the measurement folder itself
        o.joinpath("ids").mkdir()
        f = f.rename(o / "ids" / ID)
    fd = tmp_path / "fd"
    shutil.copytree(fit_dir, fd)
    argv = [str(a) for a in dict(_cases(f, o, fd))[name]]
    before = {root: _fingerprint(root) for root in (f, fd)}
    outside = _fingerprint(o)
    result = runner.invoke(app, argv)
    assert result.exit_code == 2, (argv, result.output)
    assert result.exception is None or isinstance(result.exception, SystemExit)
    errors = [x for x in result.stderr.splitlines() if x.startswith("error: ")]
    assert len(errors) >= 1 and all("Traceback" not in x for x in result.output.splitlines())
    assert any(w in errors[0] for w in ("is the input file", "inside the input folder",
                                        "holds the input")), errors
    for root, fingerprint in before.items():
        assert _fingerprint(root) == fingerprint, (name, root)
    assert _fingerprint(o) == outside  # nothing written elsewhere either


def test_check_never_writes(good, tmp_path):
    f = tmp_path / "folder"
    shutil.copytree(good, f)
    before = _fingerprint(tmp_path)
    assert runner.invoke(app, ["check", str(f)]).exit_code == 0
    assert _fingerprint(tmp_path) == before


# ------------------------------------------------------------------ outputs of the wrong kind

def test_reports_that_is_a_file_fails_before_the_fit_and_leaves_nothing(good, tmp_path):
    (tmp_path / "reports").write_text("not a folder")
    result = runner.invoke(app, ["fit", str(good), "--out", str(tmp_path / "fits"),
                                 "--reports", str(tmp_path / "reports"), "--only", "CFz"])
    assert result.exit_code == 2
    assert "--reports: is not a folder" in result.stderr
    assert "load:" not in result.stdout  # refused before the data was even read
    assert not (tmp_path / "fits").exists()


def test_tir_path_that_is_a_directory_fails_before_the_fit(good, tmp_path):
    tir_dir = tmp_path / "fits" / ID / f"{ID}.tir"
    tir_dir.mkdir(parents=True)
    result = runner.invoke(app, ["fit", str(good), "--out", str(tmp_path / "fits"),
                                 "--no-report", "--only", "CFz"])
    assert result.exit_code == 2
    assert f"{ID}.tir: --out: is a directory, expected a file" in result.stderr
    assert "fit: CFz" not in result.stdout  # before any fit
    assert sorted(p.name for p in (tmp_path / "fits" / ID).iterdir()) == [f"{ID}.tir"]


def test_a_failed_fit_directory_write_leaves_no_folder(tmp_path, monkeypatch):
    """The rename of the .tir fails after the others were prepared: no fit.json names it,
    and the folder the write made is gone."""
    from identify.io import fitdir

    def boom(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(fitdir, "format_tir", boom)
    target = tmp_path / "fits" / "x"
    with pytest.raises(OSError):
        fitdir.write_fit_dir(_tiny_run(), target, points=__import__("pandas").DataFrame())
    assert not (tmp_path / "fits").exists()


def _tiny_run():
    from identify.core.tyre import TyreInfo
    from identify.fit.run import FitRun, Provenance

    return FitRun(tyre=TyreInfo(id="x", nominal_pressure_Pa=2.5e5, nominal_load_N=5e3,
                                unloaded_radius_m=0.3),
                  provenance=Provenance.now(command="test", seed=0, settings=None,
                                            checksums={}, folder="."),
                  results=(), key_sources={}, fittyp=61, tir_name="x.tir")


def test_output_checks_name_the_kind(tmp_path):
    (tmp_path / "file").write_text("x")
    (tmp_path / "dir").mkdir()
    with pytest.raises(Exception, match="is a directory"):
        check_file_output(tmp_path / "dir")
    with pytest.raises(Exception, match="is not a folder"):
        check_folder_output(tmp_path / "file")
    with pytest.raises(Exception, match="is not a folder"):
        check_file_output(tmp_path / "file" / "below.csv")
    with pytest.raises(Exception, match="holds the input file"):
        check_folder_output(tmp_path, Inputs.of(files=(tmp_path / "dir" / "a.csv",)))
    assert check_file_output(tmp_path / "new.csv", Inputs.of(
        files=(tmp_path / "file",), folders=(tmp_path / "dir",))) == tmp_path / "new.csv"


# ------------------------------------------------------------------ paths read from files

def test_report_refuses_a_tyre_id_edited_in_fit_json(fit_dir, tmp_path, monkeypatch):
    fd = tmp_path / "fd"
    shutil.copytree(fit_dir, fd)
    doc = json.loads((fd / "fit.json").read_text())
    doc["tyre"]["id"] = "../../../escaped"
    (fd / "fit.json").write_text(json.dumps(doc))
    work = tmp_path / "a" / "b" / "c"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    before = _fingerprint(tmp_path)
    result = runner.invoke(app, ["report", str(fd)])
    assert result.exit_code == 2, result.output
    assert "fit.json: tyre.id: '../../../escaped' is not a safe file name" in result.stderr
    assert _fingerprint(tmp_path) == before


def test_a_chain_path_recorded_in_fit_json_stays_in_the_fit_directory(tmp_path):
    from identify.io.fitdir import FitDir

    outside = tmp_path / "outside.h5"
    outside.write_bytes(b"x")
    fd = FitDir.__new__(FitDir)
    object.__setattr__(fd, "path", tmp_path / "fd")
    result = type("R", (), {"relation": "MF", "form": "Fy0",
                            "mcmc": type("M", (), {"chain_file": str(outside)})()})()
    assert fd.chain_file(result) is None
    result.mcmc.chain_file = "../outside.h5"
    assert fd.chain_file(result) is None


# ------------------------------------------------------------------ stale temporaries

def test_a_killed_writers_temporary_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "r.pdf"
    dead = tmp_path / f".r.pdf.{dead_pid()}.abcd1234.tmp"
    alive = tmp_path / f".r.pdf.{os.getpid()}.abcd1234.tmp"  # a writer still running
    other = tmp_path / f".s.pdf.{dead_pid()}.abcd1234.tmp"  # another target's
    foreign = tmp_path / ".r.pdf.notours.tmp"  # not our pattern
    for p in (dead, alive, other, foreign):
        p.write_text("partial")
    atomic_write_text(target, "done")
    assert target.read_text() == "done"
    assert not dead.exists() and alive.exists() and other.exists() and foreign.exists()
    assert remove_stale(target) == []

