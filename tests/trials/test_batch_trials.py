"""The long trials of tests/integration/test_batch.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

from distributed import LocalCluster

from tests.integration.test_batch import (  # noqa: F401 - folders: a fixture, used by name
    IDS,
    _check_same_as_separate_fits,
    folders,
)
from tests.integration.test_batch import (
    test_killed_worker_costs_a_retry_and_bad_input_is_reported as _killed_worker,
)


def test_batch_matches_separate_fits_on_pool_and_dask(folders, tmp_path):  # noqa: F811
    """Issue 16, acceptance 1: the outputs of `mfid batch` on four folders equal those of four
    `mfid fit` runs (as in the test above), on the process pool, on a 2-worker Dask
    LocalCluster reached through its tcp:// address, and on `--scheduler local --workers 2`
    (which starts such a cluster itself)."""
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        _check_same_as_separate_fits(folders, tmp_path, IDS, {
            "pool": ["--workers", "2"], "tcp": ["--scheduler", cluster.scheduler_address],
            "local": ["--scheduler", "local", "--workers", "2"]})


def test_killed_dask_worker_costs_a_retry_and_bad_input_is_reported(folders, tmp_path):  # noqa: F811
    """The kill-and-retry case of the default run on the Dask engine (its retry is the
    scheduler's own)."""
    _killed_worker(folders, tmp_path, ["--scheduler", "local"])
