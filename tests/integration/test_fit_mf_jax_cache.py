"""The on-disk cache of compiled MF stage Jacobians (identify.fit.mf.jax_cache).

* A stage's Jacobian from a stored executable is bit-identical to the freshly traced one, and
  a later process-level miss loads the entry without tracing.
* An entry that is corrupt (one byte flipped: its checksum), truncated, of another JAX
  version (its key differs) or of another program (a different stage's executable under this
  key) is ignored: the stage is traced afresh, gives the same Jacobian, and the entry is
  replaced by a good one.
* ``MFID_JAX_CACHE=`` (empty) stores nothing.
* An executable JAX took from its own compilation cache (the user's JAX_COMPILATION_CACHE_DIR)
  is not stored: it would not run when loaded.
* Entries unused for UNUSED_DAYS are deleted when one is written.
* A run whose stages are all too small for the exact Jacobian does not import JAX.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from identify.fit.mf import jacobian as mf_jacobian
from identify.fit.mf import jax_cache as mf_jax_cache
from identify.fit.mf.stages import stage_problem
from tests.unit import test_fit_mf_stages as _stages

HAVE_JAX = mf_jacobian._jax() is not None
pytestmark = pytest.mark.skipif(not HAVE_JAX, reason="JAX not installed (pip install .[fast])")

truth, data = _stages.truth, _stages.data
STAGE = "My"
"""A stage that traces and compiles quickly (8 coefficients)."""


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """An empty stage cache in tmp_path, this process's executables forgotten, the exact
    Jacobian forced, and a count of the stages traced."""
    monkeypatch.setenv(mf_jax_cache.CACHE_ENV, str(tmp_path))
    monkeypatch.setenv(mf_jacobian.ENV, "jax")
    monkeypatch.setattr(mf_jacobian, "_EXECUTABLES", {})
    traced = []
    compiled = mf_jacobian._compiled

    def counting(*args):
        traced.append(args[0])
        return compiled(*args)
    monkeypatch.setattr(mf_jacobian, "_compiled", counting)
    return tmp_path, traced


def _jacobian(truth, data, stage=STAGE):
    """The stage's exact Jacobian at its start values (a new process's view: no executables
    of this process)."""
    mf_jacobian._EXECUTABLES.clear()
    p = stage_problem(stage, data, truth, screen=False).problem
    assert p.jacobian is not None
    return p.model_jacobian(p.x0())


def _entries(where):
    return sorted((where / "stages").glob("*.bin"))


def test_stored_executable_gives_the_traced_jacobian_bit_for_bit(cache, truth, data):
    where, traced = cache
    fresh = _jacobian(truth, data)
    assert traced == [STAGE] and len(_entries(where)) == 1
    loaded = _jacobian(truth, data)
    assert traced == [STAGE]  # not traced again: loaded from the entry
    assert loaded.shape == fresh.shape and np.array_equal(loaded, fresh)


def _head_and_payload(entry):
    blob = entry.read_bytes()
    magic, key, digest, payload = blob.split(b"\n", 3)
    assert magic + b"\n" == mf_jax_cache.MAGIC
    return key, payload


def _flip(payload: bytes) -> bytes:
    middle = len(payload) // 2
    return payload[:middle] + bytes([payload[middle] ^ 0xFF]) + payload[middle + 1:]


@pytest.mark.parametrize("damage", ["one byte flipped", "garbage", "truncated", "empty payload",
                                    "not an entry"])
def test_a_corrupt_entry_is_traced_afresh_and_replaced(cache, truth, data, damage):
    where, traced = cache
    fresh = _jacobian(truth, data)
    (entry,) = _entries(where)
    good = entry.read_bytes()
    key, payload = _head_and_payload(entry)
    head = good[:len(good) - len(payload)]
    entry.write_bytes({"one byte flipped": head + _flip(payload),
                       "garbage": head + bytes(range(256)) * 40,
                       "truncated": head + payload[:len(payload) // 2],
                       "empty payload": head,
                       "not an entry": b"\x00" * 100}[damage])
    again = _jacobian(truth, data)
    assert traced == [STAGE, STAGE]
    assert np.array_equal(again, fresh)
    _, repaired = _head_and_payload(entry)
    assert entry.read_bytes().startswith(head[:-65]) and len(repaired) == len(payload)
    assert np.array_equal(_jacobian(truth, data), fresh) and len(traced) == 2


def test_an_entry_of_another_jax_version_is_not_used(cache, truth, data):
    where, traced = cache
    fresh = _jacobian(truth, data)
    (entry,) = _entries(where)
    key, payload = _head_and_payload(entry)
    other = json.loads(key)
    assert other["jax"] and other["mfid"] and other["source"]
    other["jax"] = "0.0.1"
    entry.write_bytes(mf_jax_cache._head(json.dumps(other, sort_keys=True), payload) + payload)
    again = _jacobian(truth, data)
    assert traced == [STAGE, STAGE] and np.array_equal(again, fresh)
    assert _head_and_payload(entry)[0] == key  # replaced by this version's


def test_another_programs_executable_under_the_key_is_not_used(cache, truth, data):
    """A payload that deserializes but is another stage's (other arguments) falls back."""
    where, traced = cache
    fresh = _jacobian(truth, data)
    other = _jacobian(truth, data, "Mx")
    assert traced == [STAGE, "Mx"]
    (mine,) = [e for e in _entries(where) if b'"stage": "My"' in e.read_bytes()[:4000]]
    (theirs,) = [e for e in _entries(where) if e != mine]
    key, _ = _head_and_payload(mine)
    payload = _head_and_payload(theirs)[1]
    mine.write_bytes(mf_jax_cache._head(key.decode(), payload) + payload)  # a valid checksum
    again = _jacobian(truth, data)
    assert traced == [STAGE, "Mx", STAGE] and np.array_equal(again, fresh)
    assert other.shape[1] != fresh.shape[1] or not np.array_equal(other, fresh)


def test_no_cache_directory_stores_nothing(cache, truth, data, monkeypatch):
    where, traced = cache
    monkeypatch.setenv(mf_jax_cache.CACHE_ENV, "")
    assert mf_jax_cache.directory() == ""
    fresh = _jacobian(truth, data)
    assert not (where / "stages").exists()
    assert np.array_equal(_jacobian(truth, data), fresh) and traced == [STAGE, STAGE]


def test_a_run_below_the_exact_jacobian_threshold_does_not_import_jax():
    """Whether a small stage uses the exact Jacobian is decided without importing JAX (~0.3 s);
    a large one imports it (a fresh interpreter: this one has JAX loaded)."""
    code = ("import sys; from identify.fit.mf import jacobian as m; "
            "small = m.use_exact(m.MIN_WORK // 10 - 1, 9); loaded = 'jax' in sys.modules; "
            "large = m.use_exact(m.MIN_WORK, 9); print(small, loaded, large, 'jax' in sys.modules)")
    env = {**os.environ, mf_jacobian.ENV: "auto"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=Path(__file__).resolve().parents[2], check=True).stdout.split()
    assert out == ["False", "False", "True", "True"]


def test_entries_unused_for_a_month_are_deleted_when_one_is_written(cache, truth, data):
    where, traced = cache
    (where / "stages").mkdir()
    old, recent = where / "stages" / "old.bin", where / "stages" / "recent.bin"
    for entry, days in ((old, mf_jax_cache.UNUSED_DAYS + 1), (recent, 1)):
        entry.write_bytes(b"an entry of an older mfid")
        os.utime(entry, (time.time() - days * 86400,) * 2)
    _jacobian(truth, data)
    assert not old.exists() and recent.exists() and len(_entries(where)) == 2


def test_a_cache_that_fails_mid_write_and_on_cleanup_is_no_error(cache, truth, data,
                                                                 monkeypatch):
    """A cache directory that takes the temporary file but neither the rename nor its removal
    (a network share gone away): the Jacobian is the traced one and nothing is stored; the
    failed cleanup's OSError does not end the fit."""
    where, traced = cache
    real = {"replace": os.replace, "unlink": os.unlink}

    def failing(name):
        def call(path, *args, **kwargs):
            if str(args[0] if name == "replace" else path).startswith(str(where)):
                raise OSError(f"{name}: the share went away")
            return real[name](path, *args, **kwargs)
        return call
    with monkeypatch.context() as m:
        for name in real:
            m.setattr(os, name, failing(name))
        fresh = _jacobian(truth, data)
    assert traced == [STAGE] and not _entries(where)
    assert np.array_equal(fresh, _jacobian(truth, data), equal_nan=True)  # traced again
    assert traced == [STAGE, STAGE] and len(_entries(where)) == 1  # and now stored


def test_sigterm_mid_write_leaves_no_partial_entry(cache, truth, data, monkeypatch):
    """The interrupt identify.cli.entry raises for SIGTERM, arriving as an entry is renamed
    into place: it ends the run, and the partial entry is removed, not left for prune."""
    from identify.cli.entry import Interrupted

    where, _ = cache
    real = os.replace

    def interrupted(src, dst, *args, **kwargs):
        if str(dst).startswith(str(where)):
            raise Interrupted(15)
        return real(src, dst, *args, **kwargs)
    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(Interrupted):
        _jacobian(truth, data)
    assert list(where.rglob("*.tmp")) == [] and not _entries(where)


def test_prune_deletes_old_entries_and_old_partial_writes_only(tmp_path):
    """A write cut short (the process killed between mkstemp and os.replace) leaves a .tmp
    file that no run would ever load or replace: prune deletes it once as old as an unused
    entry, and nothing else (a recent one may be a write under way; other files are not
    ours)."""
    now = time.time()
    files = {"old.bin": 31, "new.bin": 1, "old.bin1x2y.tmp": 31, "new.bin3z4w.tmp": 1,
             "notes.txt": 31}
    for name, days in files.items():
        (tmp_path / name).write_bytes(b"x")
        os.utime(tmp_path / name, (now - days * 86400,) * 2)
    mf_jax_cache.prune(tmp_path, days=30)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.bin", "new.bin3z4w.tmp",
                                                          "notes.txt"]


_JACOBIAN_SCRIPT = """
import sys
import numpy as np
from identify.fit.mf.stages import stage_problem
from tests.unit.test_fit_mf_stages import _simulate, _sweeps, _truth
truth = _truth()
p = stage_problem("My", _simulate(truth, _sweeps()), truth, screen=False).problem
np.save(sys.argv[1], p.model_jacobian(p.x0()))
"""


def test_an_executable_from_jaxs_own_cache_is_not_stored(tmp_path):
    """With the user's own JAX compilation cache on (JAX_COMPILATION_CACHE_DIR), a stage
    compiled from it serializes without its code (jax 0.10.2): no entry is written, and the
    Jacobian is the same (three fresh interpreters: the first fills JAX's cache only)."""
    root = Path(__file__).resolve().parents[2]
    for run in range(3):
        env = {**os.environ, mf_jacobian.ENV: "jax",
               "JAX_COMPILATION_CACHE_DIR": str(tmp_path / "jax"),
               "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0",
               mf_jax_cache.CACHE_ENV: "" if run == 0 else str(tmp_path / "mfid")}
        subprocess.run([sys.executable, "-c", _JACOBIAN_SCRIPT, str(tmp_path / f"J{run}.npy")],
                       env=env, cwd=root, check=True, capture_output=True)
    assert any((tmp_path / "jax").iterdir())  # JAX's cache was used
    assert not list((tmp_path / "mfid").glob("stages/*.bin"))
    first = np.load(tmp_path / "J0.npy")
    for run in (1, 2):
        assert np.array_equal(np.load(tmp_path / f"J{run}.npy"), first, equal_nan=True)
