"""The plausibility ranges fit real rigs (issue 44): every real TTC set beside the project
imports and passes ``mfid check`` with no error and no warning about a force, moment, slip
ratio, time stamp or time step. Skipped where ``../shared/realdata`` is absent."""
from __future__ import annotations

import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from tests.realdata import SETS, trailer_files

pytestmark = pytest.mark.trials

RANGES = ("largest force", "largest moment", "largest slip", "largest time", "time step")


@pytest.mark.parametrize("folder", SETS, ids=lambda d: getattr(d, "name", "absent"))
def test_every_real_set_passes_check_within_the_ranges(tmp_path, folder):
    runner = CliRunner()
    imported = runner.invoke(app, ["import", *map(str, trailer_files(folder)), "--out",
                                   str(tmp_path / "set")])
    assert imported.exit_code == 0, imported.output
    result = runner.invoke(app, ["check", str(tmp_path / "set")])
    assert result.exit_code == 0, result.stderr
    assert not [x for x in result.stderr.splitlines() if any(r in x for r in RANGES)]
