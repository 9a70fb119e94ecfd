"""The long trials of tests/integration/test_ttc_fit.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pytest

from identify.cli.app import app
from tests.integration.test_ttc_fit import (
    _check_fit,
    _fit,
    _tree_hashes,
    runner,
)
from tests.integration.test_ttc_fit import (
    test_import_then_fit_a_short_session_without_hand_edits as _short_session,
)
from tests.ttc_cases import session


@pytest.mark.parametrize("suffix", [".mat", ".dat"])
def test_import_then_fit_the_full_session_without_hand_edits(tmp_path, suffix):
    """Acceptance 1: the generated two-run session (cornering ~60k samples at 3 pressures,
    drive/brake ~77k) in .mat and in .dat: mfid import -> mfid fit, exit 0."""
    s = session(tmp_path / "ttc", seed=3)
    files = [f for f in s.files if f.suffix == suffix]
    before_in = _tree_hashes(s.path)
    folder = tmp_path / "folder"
    result = runner.invoke(app, ["import", *map(str, files), "--out", str(folder)])
    assert result.exit_code == 0, result.stderr
    assert _tree_hashes(s.path) == before_in
    before = _tree_hashes(folder)
    _check_fit(folder, tmp_path, _fit(folder, tmp_path), before)


def test_import_then_fit_a_short_session_from_dat_without_hand_edits(tmp_path):
    """The default run's short session (two runs decimated 10x), read from the TTC .dat text
    files instead of the .mat files: imported and fitted with exit 0."""
    _short_session(tmp_path, ".dat")
