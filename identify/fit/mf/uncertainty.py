"""Standard errors of the staged MF fit that carry the uncertainty of earlier stages.

The MF stages are fitted one after the other (identify.fit.mf.stages.fit_mf): the combined-slip
stages hold the pure-slip coefficients at their fitted values, Mz0 holds Fy0's, and so on. Each
stage's own covariance (the delete-one-sweep jackknife, identify.fit.solve.engine.covariance) treats
what it holds as exact, so its intervals are too narrow by what the earlier stages did not
know: on generated TTC sessions the Fx stage's RBX1/RBX2/RCX1 intervals held the truth in 4-6
of 10 seeds while Fx0's PKX1, which Fx holds, was off by a few of its own standard errors.

:func:`propagate` recomputes every stage's covariance as one jackknife over the session's
sweeps (stacked: Hinkley's jackknife of a sequence of estimators). Leaving sweep c out moves
the earlier stages' coefficients by their steps u_c (already known, in stage order) and the
stage's own by d_c = (G - G_c)^+ (s_c - (J^T K - J_c^T K_c) u_c) (identify.fit.solve.engine.
jackknife_steps), K = d r / d (the coefficients earlier stages fixed), by central differences.
A sweep that has no point in the stage still moves it through u_c. The covariance is
(C - 1)/C sum_c d_c d_c^T over all C sweeps of the table; FitResult.covariance is then
"staged-sweep-jackknife". The degrees of freedom of each standard error (FitResult.dof) are
Satterthwaite's for the stage's own sweeps (identify.fit.solve.engine.jackknife_dof).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pandas as pd

from identify.fit.mf import stage_data as mf_data
from identify.fit.mf.problem import StageProblem, fitted_problem
from identify.fit.mf.result import MFFit
from identify.fit.mf.stage_specs import names_read, stage_model
from identify.fit.result import FitResult
from identify.fit.solve import engine
from identify.fit.solve.trf_svd import tall_svd

__all__ = ["STAGED", "propagate"]

STAGED = "staged-sweep-jackknife"
"""FitResult.covariance of a stage whose covariance carries the earlier stages'."""


BATCH_ELEMENTS = 1 << 16
"""Elements (perturbed parameter sets x points) of one vectorised evaluation of the central
differences in :func:`_upstream_jacobian`: 512 kB per intermediate array, within a core's
cache: a batch whose intermediates leave the cache can be slower than one set at a time."""


def _upstream_jacobian(sp: StageProblem, x: np.ndarray, params: Mapping[str, float],
                       names: list[str]) -> np.ndarray:
    """d(weighted residuals of the stage at x) / d(names), coefficients of earlier stages that
    the stage holds (central differences, engine.fd_jacobian's steps), (points, len(names)).

    The perturbed parameter sets are evaluated together, a batch at a time: the model takes
    arrays of shape (sets, 1) for its values (as for MCMC walkers), so the stage's inputs
    (identify.fit.mf.stage_specs.stage_inputs, the earlier stages' forces at every point) are
    computed once per batch instead of twice per name; each element is the same arithmetic
    as one set at a time. A name the stage's equations do not read (names_read: Mx reads
    no longitudinal coefficient) has an exactly zero column without evaluating."""
    problem = sp.problem
    values = problem.values(x)
    n = problem.measured.size
    cols = np.zeros((n, len(names)))
    # a coefficient the stage's equations never read has an exactly zero column (the
    # prediction at every perturbed value is the same arithmetic on the same numbers)
    read = names_read(problem.form, {**params, **values}, sp.state, sp.omega)
    used = [j for j, m in enumerate(names) if m in read]
    if not used:
        return cols
    cols[:, used] = _central_differences(sp, values, params, [names[j] for j in used])
    return cols


def _central_differences(sp: StageProblem, values: Mapping[str, float],
                         params: Mapping[str, float], names: list[str]) -> np.ndarray:
    """The columns of :func:`_upstream_jacobian` of ``names``, evaluated in batches."""
    problem = sp.problem
    w = problem.weights()
    phi = np.array([float(params[n]) for n in names])
    h = engine.fd_steps(phi)  # engine.fd_jacobian's steps, no bounds
    up, down = phi + h, phi - h
    n = problem.measured.size
    batch = max(1, BATCH_ELEMENTS // max(2 * n, 1))
    cols = np.empty((n, len(names)))
    for a in range(0, len(names), batch):
        js = np.arange(a, min(a + batch, len(names)))
        sets = np.tile(phi, (2 * js.size, 1))
        sets[2 * np.arange(js.size), js] = up[js]
        sets[2 * np.arange(js.size) + 1, js] = down[js]
        base = {**params, **{m: sets[:, j:j + 1] for j, m in enumerate(names)}}
        model = stage_model(problem.form, base, sp.state, sp.omega)
        with np.errstate(all="ignore"):
            r = (np.broadcast_to(np.asarray(model(values), dtype=float), (2 * js.size, n))
                 - problem.measured) * w
            cols[:, js] = ((r[0::2] - r[1::2]) / (up[js] - down[js])[:, None]).T
    return np.where(np.isfinite(cols), cols, 0.0)


UNDETERMINED_RCOND = 1e-10
"""A direction of a stage's coefficients is undetermined by its data when its squared singular
value of the column-scaled Jacobian is below this fraction of the largest (a standard error
along it 1e5 times the best-determined direction's, see :func:`_determined`). The stages'
data determine their directions far above this; a direction below it is one of rounding, as
Fx0's when its fit ends with PKX2 at 0 (as on some generated TTC sessions of
bench/ttc_truth.py), where the PKX2 and PKX3 columns are proportional,
d Kx / d PKX3 = PKX1 x d Kx / d PKX2."""


def _determined(jac: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """``steps`` (C, k) less their components along the directions that ``jac`` (n, k) leaves
    undetermined (UNDETERMINED_RCOND), in column-scaled coefficients: what a stage's jackknife
    steps carry into the later stages.

    Along such a direction the linearised step of a left-out sweep divides that sweep's
    score by a singular value at the rounding level; it is no estimate of how the coefficient
    varies, and the stage's own covariance says so (no finite standard error, or a pair
    correlated above 0.99: identify.fit.identifiability). Carried downstream through the
    stage's effect on the later stages' points, such steps would swamp their jackknife
    (an Fx0 fit ending at PKX2 ~ 0 would leave most of Mz0's coefficients, which take Fx0's
    in, not identifiable). Without them, the later stages' intervals are conditional on the
    value the fit left along the undetermined direction, as they are on a held
    coefficient's."""
    Js, scale = engine.column_scaled(jac)
    _, sv, Vt = tall_svd(Js, full_matrices=False)  # the thin SVD without forming U
    null = Vt[sv ** 2 < UNDETERMINED_RCOND * sv[0] ** 2] if sv.size else Vt[:0]
    if not null.size:
        return steps
    z = steps * scale
    return (z - (z @ null.T) @ null) / scale


def _with_covariance(r: FitResult, free: tuple[str, ...], cov: np.ndarray,
                     clusters: int, dof: np.ndarray) -> FitResult:
    stderr, corr = engine.standard_errors(free, cov)
    return dataclasses.replace(r, stderr=stderr, correlations=corr, covariance=STAGED,
                               clusters=clusters, dof=dict(zip(free, map(float, dof))))


def propagate(trailer: pd.DataFrame, mf: MFFit) -> MFFit:
    """``mf`` with every sweep-clustered stage's standard errors and correlations from the
    stacked delete-one-sweep jackknife (see module); stages with the iid covariance (too few
    sweeps, or one sweep alone determines a combination: engine.jackknife_defined) and their
    coefficients are left as they are (their steps count as 0 downstream).

    Parameters
    ----------
    trailer : DataFrame
        The table ``mf`` was fitted on (the same rows: the stages' points are found again).
    mf : MFFit
        The staged fit (each stage at its own optimum given the others' values).
    """
    labels = mf_data.sweep_ids(trailer, float(mf.params["FNOMIN"]))
    n_sweeps = int(labels.max(initial=-1)) + 1
    steps: dict[str, np.ndarray] = {}
    results = []
    for r in mf.results:
        sp = fitted_problem(trailer, mf.params, r) if r.free else None
        if (sp is None or r.covariance != "sweep-jackknife" or sp.problem.clusters() is None
                or sp.problem.free != r.free):
            results.append(r)
            continue
        problem = sp.problem
        x = np.array([float(mf.params[n]) for n in problem.free])
        J = engine.residual_jacobian(problem, x)
        fun = problem.residuals(x)
        lab = labels[sp.rows]
        clusters = [np.flatnonzero(lab == c) for c in range(n_sweeps)]
        names = [n for n in steps if n not in problem.free]
        upstream, moved = None, np.zeros(n_sweeps, dtype=bool)
        if names:
            K = _upstream_jacobian(sp, x, mf.params, names)
            keep = np.flatnonzero(np.any(K != 0, axis=0))
            if keep.size:
                U = np.column_stack([steps[names[j]] for j in keep])
                upstream = (K[:, keep], U)
                moved = np.any(U != 0, axis=1)
        # the sweeps that move this stage: its own, and those that move what it holds
        used = np.flatnonzero(moved | np.array([c.size > 0 for c in clusters]))
        up = None if upstream is None else (upstream[0], upstream[1][used])
        sub = [clusters[c] for c in used]
        own = np.zeros((n_sweeps, len(problem.free)))
        own[used] = engine.jackknife_steps(J, fun, sub, up)
        cov = engine.jackknife_covariance(own[used])
        # downstream, only what the stage's data determine moves (see _determined)
        carried = _determined(J, own)
        for j, n in enumerate(problem.free):
            steps[n] = carried[:, j]
        # degrees of freedom from the stage's own sweeps (engine.jackknife_dof; a sweep that
        # moves the stage only through what it holds adds no term of its own)
        dof = engine.jackknife_dof(J, [c for c in sub if c.size])
        results.append(_with_covariance(r, problem.free, cov, used.size, dof))
    return dataclasses.replace(mf, results=tuple(results))
