"""Shared test fixtures and the suite's layout.

tests/unit holds fast tests of one module's promise, tests/integration tests of whole commands
and pipelines, tests/trials the long statistical trials and the real-data checks: every test
under tests/trials carries the ``trials`` marker (deselected by default, ``make trials`` runs
them). Helper modules (``tests/*_cases.py``, ``tests/realdata.py`` ...) stay here, importable
from all three as ``tests.<name>``.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

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


#: A module-scoped fixture declared in a test module.
_MODULE_FIXTURE = re.compile(r"""@pytest\.fixture\([^)]*scope=["']module["']""")


def pytest_xdist_make_scheduler(config, log):
    """``pytest -n N``: each test module that declares a module-scoped fixture (often a
    simulated folder or a whole fit) runs on one worker, so the fixture is built once rather
    than once per worker; those modules are handed out first (most tests first), the other
    tests one at a time after them, which keeps the workers busy to the end. Other ``--dist``
    modes keep pytest-xdist's own scheduling."""
    if config.getoption("dist") != "load":
        return None
    from xdist.scheduler import LoadScopeScheduling

    root = Path(str(config.rootpath))
    shared: dict[str, bool] = {}

    def pinned(module: str) -> bool:
        if module not in shared:
            path = root / module
            shared[module] = path.suffix == ".py" and path.is_file() and bool(
                _MODULE_FIXTURE.search(path.read_text(encoding="utf-8")))
        return shared[module]

    class ModuleFixtureScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return module if pinned(module) else nodeid

    return ModuleFixtureScheduling(config, log)
