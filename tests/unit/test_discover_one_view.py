"""One view of the data (issue 45): a library coefficient that a fit of the same points
identifies beyond 5 standard errors is testable in discovery, and the two agree on its sign
and size within their intervals. Generated session, seconds; the real sessions are in
tests/trials/test_discovery_real_trials.py."""
from __future__ import annotations

import numpy as np
import pytest

from identify.discover.library import load_library
from identify.discover.scenarios import Matrix, make_problem
from identify.discover.search import Settings, discover
from identify.fit.optimize import fit
from identify.fit.solve.problem import with_free

SE_LIMIT = 5.0


@pytest.fixture(scope="module")
def session():
    """MF/Fy at three pressures, PPY3 = -0.15 in the data (peak friction falls with
    pressure, as on the Formula Student sessions), the base without pressure terms."""
    problem, truth = make_problem("MF/Fy", np.random.default_rng(3), "PPY3", -0.15,
                                  matrix=Matrix(density=0.3))
    return problem, truth


def test_what_the_fit_identifies_discovery_tests_and_agrees_on(session):
    problem, truth = session
    library = load_library()
    cands = {c.name: c for c in library.for_problem("MF/Fy") if not c.nuisance}
    free = {k: v for c in cands.values() for k, v in c.coefficients.items()}
    bounds = {k: b for c in cands.values() for k, b in c.bounds.items()}
    fitted = fit(with_free(problem, free, bounds), n_starts=1)
    identified = {k for k in free
                  if abs(fitted.parameters[k]) > SE_LIMIT * fitted.stderr[k]}
    assert "PPY3" in identified  # the case: the fit sees the effect in the data

    d = discover([problem], library, Settings())
    rows = {r.name: r for r in d.steps[0].candidates}
    assert all(rows[k].testable for k in identified), {k: rows[k].rel_norm for k in identified}
    named = {k: (a.coefficients[k], a.stderr[k]) for a in d.accepted
             for k in a.coefficients}
    for k in identified & set(named):
        v, se = named[k]
        assert np.sign(v) == np.sign(fitted.parameters[k])
        assert abs(v - fitted.parameters[k]) < 3.0 * np.hypot(se, fitted.stderr[k])
    assert "PPY3" in named
    assert named["PPY3"][0] == pytest.approx(truth["value"], abs=4 * named["PPY3"][1] + 0.01)
