"""The long trials of tests/unit/test_fit_mf_stages.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pytest

from identify.fit.mf.stages import DEFAULT_STAGES, fit_mf
from tests.unit.test_fit_mf_stages import (  # noqa: F401 - fixtures, used by name
    RECOVERY_RTOL,
    SAMPLE,
    _perturb,
    _rel_errors,
    data,
    free_sets,
    truth,
)


@pytest.mark.parametrize("seed", [2, 3, 4, 5, 6])
def test_recovery_from_other_perturbations(seed, truth, data, free_sets):  # noqa: F811
    for stage in DEFAULT_STAGES:
        start = _perturb(truth, free_sets[stage], seed=seed)
        result = fit_mf(data, start, stages=(stage,)).result(stage)
        errors = _rel_errors(result, truth)
        worst = max(errors, key=errors.get)
        assert errors[worst] <= RECOVERY_RTOL, (stage, worst, errors[worst])


def test_bundled_sample_all_stages_from_the_defaults():
    """What ``mfid fit`` does with the bundled folder's trailer runs: MFeval defaults with the
    folder's nominal conditions as the start; every stage converges to the 1 % noise."""
    from identify.io.folder import load_folder
    from identify.model.parameters import defaults

    mset = load_folder(SAMPLE.parent)
    base = {k: v for k, v in defaults().items() if not isinstance(v, str)}
    tyre = mset.manifest.tyre
    base.update(FNOMIN=float(tyre.nominal_load_N), NOMPRES=float(tyre.nominal_pressure_Pa),
                INFLPRES=float(tyre.nominal_pressure_Pa),
                UNLOADED_RADIUS=float(tyre.unloaded_radius_m))
    mf = fit_mf(mset.trailer, base)
    assert [r.form for r in mf.results] == list(DEFAULT_STAGES)
    for r in mf.results:
        print(f"{r.form}: {r.error_total_pct:.3f} %, {r.seconds:.1f} s")
        assert r.converged, (r.form, r.message)
        assert r.error_total_pct < 1.2, r.form
