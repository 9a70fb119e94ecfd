"""Worker processes of one fit (identify.core.workers): the MF stages' profile intervals and the
report's pages computed in other processes give what the serial path gives, number for number
and page for page."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from identify.core import workers
from identify.fit.mf.profile import profile_intervals
from identify.fit.mf.stages import fit_mf
from tests.unit import test_fit_mf_stages as _stages
from tests.unit.test_fit_calibration_mf import add_noise

# the stage tests' fixtures: the truth and its simulated sweeps
truth, data = _stages.truth, _stages.data


@pytest.fixture(scope="module")
def pool():
    with workers.process_pool(2) as p:
        yield p


def test_profile_intervals_in_workers_are_the_serial_ones(truth, data, pool):
    noisy = add_noise(data, 0)
    mf = fit_mf(noisy, truth, stages=("Fx0",), seed=1)
    serial = profile_intervals(noisy, mf)
    lines: list[str] = []
    parallel = profile_intervals(noisy, mf, lines.append, pool=pool)
    assert all(r.profile for r in serial.results)
    for a, b in zip(serial.results, parallel.results):
        assert dataclasses.replace(a, predicted=None, measured=None, pressure_bar=None) == \
            dataclasses.replace(b, predicted=None, measured=None, pressure_bar=None)
        assert a.profile == b.profile  # bit for bit (floats compared exactly)
    # some ends were refitted (jobs of their own), and the progress lines come in stage
    # order, whichever process finished first
    assert any("(0 refits)" not in line for line in lines), lines
    assert [line.split("]")[0] for line in lines] == \
        [f"MF [{r.form}" for r in serial.results if r.profile]


def test_default_workers_follow_the_cores_and_the_thread_variables(monkeypatch):
    for name in workers.THREAD_ENV:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(workers, "_busy", lambda: 0.0)
    monkeypatch.setattr(workers, "_cores", lambda: 2)
    assert workers.default_workers() == 2
    monkeypatch.setattr(workers, "_cores", lambda: 8)
    assert workers.default_workers() == workers.MAX_WORKERS == 2
    monkeypatch.setattr(workers, "_cores", lambda: 1)
    assert workers.default_workers() == 1
    monkeypatch.setattr(workers, "_cores", lambda: 2)
    monkeypatch.setenv("OMP_NUM_THREADS", "2")  # each process told to use both cores
    assert workers.default_workers() == 1
    monkeypatch.setenv("OMP_NUM_THREADS", "not a number")
    assert workers.default_workers() == 2
    monkeypatch.delenv("OMP_NUM_THREADS")
    # busy cores: the one fitting (load 1, its own last run) leaves one idle; load 1.6 none
    monkeypatch.setattr(workers, "_busy", lambda: 1.0)
    assert workers.default_workers() == 2
    monkeypatch.setattr(workers, "_busy", lambda: 1.6)
    assert workers.default_workers() == 1
    monkeypatch.setattr(workers, "_busy", lambda: 12.0)
    assert workers.default_workers() == 1


def test_warm_up_imports_in_every_worker(pool):
    workers.warm_up(pool, 2, ("identify.fit.mf.profile", "no_such_module_here"))
    # the pool still answers: a module that is not installed is skipped, not fatal
    assert pool.submit(np.add, 1, 2).result() == 3
