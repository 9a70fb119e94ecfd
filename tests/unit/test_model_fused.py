"""The compiled kernel against the pure-numpy reference path, over the whole input box.

Tolerance 1e-10 relative (|d|/max(1,|ref|)): both paths evaluate the same equations in double
precision; the kernel uses its own elementary functions (a few ulp, tests/unit/test_kernel_math.py),
replaces cos(atan(x)) by 1/sqrt(1+x^2) (exact identity) and evaluates in a different order,
and the Magic Formula amplifies round-off by at most its condition number (observed worst
2e-12). MF 6.2 rho, Rl, Cz come from an iterative solve that both paths stop at
|dFz| <= 1e-12 FNOMIN along different round-off paths; near the edge of the solvable region
(tiny deflections, flat Fz(Rl)) that leaves up to ~6e-7, so they are held to the 1e-6 used
for iterative outputs (tests/data/reference/PROVENANCE.md). Points whose secant finds no
root in the kernel are decided by the numpy path (identify.model.kernel.fused), so both paths flag
the same points.
"""
from __future__ import annotations

import numpy as np
import pytest

from identify.model.evaluate import OUTPUT_COLUMNS, evaluate
from identify.model.kernel.fused import FORCE_COLUMNS, evaluate_fused, evaluate_outputs
from tests.model_cases import params, random_points

TOL = 1e-10


@pytest.mark.parametrize("fittyp", [61, 62])
@pytest.mark.parametrize("mode", [111, 121, 211, 221])
@pytest.mark.parametrize("with_omega", [False, True])
def test_fused_matches_numpy(fittyp, mode, with_omega):
    P = params(fittyp)
    pts = random_points(3000, seed=mode + fittyp)
    omega = np.random.default_rng(1).uniform(-10, 110, 3000) if with_omega else None
    ref = evaluate(P, pts["fz"], pts["kappa"], pts["alpha"], pts["gamma"], pts["vx"], pts["p"],
                   omega=omega, mode=mode)
    got = evaluate_fused(P, pts["fz"], pts["kappa"], pts["alpha"], pts["gamma"], pts["vx"],
                         pts["p"], omega=omega, mode=mode)
    keep = np.ones(3000, bool)
    if fittyp == 62:
        # where Fz(Rl) = Fz has no root (extreme camber and load in this random box) the
        # secant wanders chaotically and round-off decides where it stops: both paths must
        # flag the same points, and only converged points are scored
        assert np.array_equal(ref["Rl_converged"], got["Rl_converged"])
        keep = ref["Rl_converged"]
        assert keep.mean() > 0.9  # ~5 % of this deliberately extreme box has no root
    for name in OUTPUT_COLUMNS + ("kappa_out", "alpha_out", "p_used", "phit_out"):  # all outputs
        a, b = ref[name][keep], got[name][keep]
        finite = np.isfinite(a) & np.isfinite(b)
        assert np.array_equal(a[~finite], b[~finite]), name  # same inf/nan where not finite
        a, b = a[finite], b[finite]
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        err = np.abs(a - b) / np.maximum(1.0, np.abs(a))
        tol = 1e-6 if (fittyp == 62 and name in ("rho", "Rl", "Cz")) else TOL
        assert np.nanmax(err) <= tol, f"{name}: worst {np.nanmax(err):.2e}"


def test_threaded_kernel_gives_identical_results():
    P = params(61)
    pts = random_points(2000, seed=11)
    args = (pts["fz"], pts["kappa"], pts["alpha"], pts["gamma"], pts["vx"], pts["p"])
    a = evaluate_fused(P, *args, mode=111)
    b = evaluate_fused(P, *args, mode=111, threads=True)
    for name in OUTPUT_COLUMNS:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


@pytest.mark.parametrize("outputs", [("Fy",), ("Fx",), ("Fx", "Fy", "Mz"), FORCE_COLUMNS,
                                     ("Mx", "Fy"), ("Re", "Cz")])
@pytest.mark.parametrize("mode", [111, 221])
def test_subset_of_outputs_equals_the_full_kernel_and_numpy(outputs, mode):
    P = params(61)
    pts = random_points(2000, seed=5)
    args = (pts["fz"], pts["kappa"], pts["alpha"], pts["gamma"], pts["vx"], pts["p"])
    got = evaluate_outputs(P, outputs, *args, mode=mode)
    full = evaluate_fused(P, *args, mode=mode)
    ref = evaluate(P, *args, mode=mode)
    assert tuple(got) == outputs
    for name in outputs:
        assert np.array_equal(got[name], full[name], equal_nan=True), name
        fin = np.isfinite(ref[name])
        assert np.array_equal(got[name][~fin], ref[name][~fin], equal_nan=True), name
        err = np.abs(got[name][fin] - ref[name][fin]) / np.maximum(1.0, np.abs(ref[name][fin]))
        assert np.max(err) <= TOL, name


def test_unknown_output_is_named():
    P = params(61)
    with pytest.raises(KeyError, match="Fw"):
        evaluate_outputs(P, ("Fy", "Fw"), [3000.0], [0.0], [0.1], [0.0], [10.0])
