"""Shared test fixtures and the suite's layout.

tests/unit holds fast tests of one module's promise, tests/integration tests of whole commands
and pipelines, tests/trials the long statistical trials and the real-data checks: every test
under tests/trials carries the ``trials`` marker (deselected by default, ``make trials`` runs
them). Helper modules (``tests/*_cases.py``, ``tests/realdata.py`` ...) stay here, importable
from all three as ``tests.<name>``.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

# ``mfid fit`` in one process: the suite already runs one test per core (xdist), and the
# worker processes' start (seconds of imports each) would cost more than they save on the
# small test sessions; the tests of the workers ask for them with --workers
os.environ.setdefault("MFID_WORKERS", "1")

#: Test data shipped with the tests.
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """tests/data."""
    return DATA


TRIALS = Path(__file__).resolve().parent / "trials"


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Mark every test under tests/trials ``trials`` before ``-m`` selects."""
    for item in items:
        if TRIALS in Path(str(item.path)).resolve().parents:
            item.add_marker(pytest.mark.trials)
