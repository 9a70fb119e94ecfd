"""The other branch of a two-branch load curve, tried after an MF stage's global fit.

The longitudinal slip stiffness is (docs/model.md, section 4)

    Kxk / Fz = (PKX1 + PKX2 dfz) exp(PKX3 dfz)      [-]

Over the loads of a trailer session (dfz within about +-0.5) two sets with the same value and
slope at dfz = 0 -- PKX2 of either sign, PKX3 = PKX3' + (PKX2' - PKX2) / PKX1 -- draw nearly
the same curve, and the search, which starts near the defaults (PKX2 > 0), does not reach the
other, though the branch through the truth may fit the same points better (a TTC session
generated from the golden test tyre, tests/data/tir/testA_61.tir with PKX2 = -10,
PKX3 = 0.5: tests/integration/test_fit_mf_other_tyre.py). After
the global fit the stage is solved once more from the mirrored point; the lower end is the
optimum, and the other, passed to identify.fit.mf.minima.rivals, is a rival when within the 95 %
region.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from identify.core.progress import Progress
from identify.fit.mf.problem import StageProblem
from identify.fit.mf.search import MAX_NFEV
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from identify.fit.solve.engine import MF_SOLVE, residual_variance

__all__ = ["BRANCHES", "TAKE_CHI2", "other_branch", "with_other_branch"]

BRANCHES = {"Fx0": ("PKX1", "PKX2", "PKX3")}
"""Stage -> (value, slope, curvature) coefficients of a load curve (c0 + c1 dfz) exp(c2 dfz)."""
TAKE_CHI2 = 0.01
"""The other branch's end replaces the search's optimum when lower by more than this in chi^2
(the optimum's residual variance); equal ends are one minimum seen twice, and the other goes
to the rivals."""


def _mirror_outside(result: FitResult, c1: str) -> bool:
    """Whether the mirrored -c1 lies outside the optimum's 95 % interval of c1
    (FitResult.interval, t(0.975, dof) standard errors: |c1| above about one standard error;
    False without a standard error): nearer 0 the mirrored point is within the optimum's own
    interval, and the two branches meet there.

    A gate at 2 standard errors would leave the branch untried where c1 lies between one and
    two standard errors from 0 and the other branch fits as well (the golden tyre's TTC
    session at seed 1 in tests/integration/test_fit_mf_other_tyre.py). The gate does not keep a
    solve at
    small c1 from ending as low as the optimum: on tests/unit/test_fit_mf_basins.py's Fx0 stage,
    PKX2 a few standard errors from 0, the other branch is tried and ends at PKX2 ~ 0 as low
    as the optimum; TAKE_CHI2 keeps the optimum, and the end is a rival in
    PKX2 alone."""
    lo, hi = result.interval(c1)
    mirror = -float(result.parameters[c1])
    return bool(mirror < lo or mirror > hi)  # NaN bounds: False


def other_branch(stage: str, values: Mapping[str, float]) -> dict[str, float] | None:
    """The start on the other branch of ``stage``'s load curve (c1 -> -c1, c2 keeping the
    slope c1 + c0 c2 at dfz = 0), or None when the stage has none or c0 or c1 is 0."""
    names = BRANCHES.get(stage)
    if names is None or not all(n in values for n in names):
        return None
    c0, c1, c2 = (float(values[n]) for n in names)
    if c0 == 0 or c1 == 0:
        return None
    return {names[1]: -c1, names[2]: c2 + 2 * c1 / c0}


def with_other_branch(result: FitResult, sp: StageProblem, label: str,
                      progress: Progress | None) -> tuple[FitResult, list[dict[str, float]]]:
    """``result`` or, when the solve from the other branch (:func:`other_branch`, its
    coefficients all free, -c1 outside the optimum's 95 % interval of c1) converges lower
    by TAKE_CHI2,
    that end (with the search's counts, the two solves' evaluations and seconds, and a note in
    its message); and the end not taken as a candidate for identify.fit.mf.minima.rivals (empty when
    the solve did not converge or was not tried)."""
    free = result.free
    start = other_branch(result.form, result.parameters)
    if start is None or not result.converged or not set(start) <= set(free):
        return result, []
    c1 = BRANCHES[result.form][1]
    if not _mirror_outside(result, c1):
        return result, []
    x0 = np.array([[start.get(n, float(result.parameters[n])) for n in free]])
    lo, hi = sp.problem.bounds()
    if np.any(x0[0] < lo) or np.any(x0[0] > hi):
        return result, []
    end = fit(sp.problem, starts=x0, max_nfev=MAX_NFEV, tol=MF_SOLVE)
    nfev, seconds = result.nfev + end.nfev, result.seconds + end.seconds
    if not end.converged:
        return dataclasses.replace(result, nfev=nfev, seconds=seconds), []
    s2 = residual_variance(0.5 * result.wls, result.n_points, len(free))
    if result.wls - end.wls > TAKE_CHI2 * s2:  # not a ratio: s2 is 0 on an exact fit
        if progress is not None:
            progress(f"{label}: the other branch of {', '.join(BRANCHES[result.form])} fits "
                     f"better (objective {end.wls / result.wls:.4g} of the search's)")
        loser = {n: float(result.parameters[n]) for n in free}
        taken = dataclasses.replace(
            end, n_starts=result.n_starts, starts_at_best=result.starts_at_best,
            nfev=nfev, seconds=seconds,
            message=f"{end.message} (from the other branch of "
                    f"{', '.join(BRANCHES[result.form])}, lower than the search's optimum)")
        return taken, [loser]
    return (dataclasses.replace(result, nfev=nfev, seconds=seconds),
            [{n: float(end.parameters[n]) for n in free}])
