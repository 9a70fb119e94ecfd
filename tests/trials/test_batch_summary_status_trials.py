"""The long trials of tests/integration/test_batch_summary_status.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

from identify.workflows.batch.run import run_batch
from tests.integration.test_batch_summary_status import (
    SAMPLE,
    _check_summary_agrees,
    _fit_statuses,
)


def test_summary_of_the_sample_says_what_every_fit_says(tmp_path):
    out = tmp_path / "fits"
    run = run_batch([SAMPLE], out_root=out, reports=tmp_path / "reports", workers=1)
    assert "poorly identified" in _fit_statuses(out / SAMPLE.name).values()
    _check_summary_agrees(run, out, [SAMPLE.name])
