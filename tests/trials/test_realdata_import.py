"""Every real TTC set beside the project imports (issue 46): exit 0, every run classed by its
sweeps, no input changed. Skipped where ``../shared/realdata`` is absent."""
from __future__ import annotations

import hashlib

import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from tests.realdata import SETS, trailer_files

pytestmark = pytest.mark.trials


@pytest.mark.parametrize("folder", SETS, ids=lambda d: getattr(d, "name", "absent"))
def test_every_real_set_imports(tmp_path, folder):
    files = trailer_files(folder)
    before = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}
    result = CliRunner().invoke(app, ["import", *map(str, files), "--out",
                                      str(tmp_path / "set")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "set" / "tyre.toml").is_file()
    assert {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in files} == before
