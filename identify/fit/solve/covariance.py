"""The covariance of least-squares estimates, and the degrees of freedom of their intervals.

One function, :func:`covariance`, from the Jacobian J of the weighted residuals r at the optimum:
s^2 (J^T J)^+ (iid), (J^T J)^+ (sigma known), or cluster-robust over sweeps (the sandwich CR1
or the delete-one-cluster jackknife, :func:`jackknife_steps`). :func:`standard_errors` turns a
covariance into standard errors and correlations. :func:`interval_dof` gives each coefficient's
degrees of freedom, so that a 95 % interval is value +/- t(0.975, dof) standard errors
(:func:`t_quantile`; docs/intervals.md). :mod:`identify.fit.solve.engine` re-exports all of it.
"""
from __future__ import annotations

import numpy as np
from scipy.special import stdtrit

__all__ = ["CLUSTER_KINDS", "ESSENTIAL_RTOL", "column_scaled", "covariance", "interval_dof",
           "jackknife_covariance", "jackknife_defined", "jackknife_dof", "jackknife_steps",
           "jackknife_with_dof", "pseudo_solve", "residual_variance", "standard_errors",
           "t_quantile"]


def pseudo_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a^+ b with the Moore-Penrose pseudo-inverse (a symmetric positive semi-definite matrix:
    a normal matrix J^T J, a score-test Gram matrix or a cluster-robust covariance block)."""
    return np.linalg.pinv(a) @ b


CLUSTER_KINDS = ("CR1", "jackknife")
"""Small-sample forms of the cluster-robust covariance (see :func:`covariance`)."""


def residual_variance(cost: float, n_points: int, n_free: int) -> float:
    """s^2 = r^T r / (n - k) from a least-squares cost 0.5 r^T r (n - k at least 1)."""
    return 2.0 * cost / max(n_points - n_free, 1)


def column_scaled(jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``jac`` (n, k) with columns of unit norm, and the norms they were divided by (1 for a
    zero column): the jackknife's k x k solves on comparable columns."""
    J = np.atleast_2d(np.asarray(jac, dtype=float))
    scale = np.linalg.norm(J, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    return J / scale, scale


def _cluster_grams(Js: np.ndarray, clusters: list[np.ndarray]) -> np.ndarray:
    """G_c = J_c^T J_c of every cluster, (C, k, k)."""
    k = Js.shape[1]
    return np.array([Js[i].T @ Js[i] for i in clusters]).reshape(len(clusters), k, k)


def _left_out(jac: np.ndarray, clusters: list[np.ndarray]) -> tuple[np.ndarray, ...]:
    """(column-scaled J, its column norms, G_c of every cluster, (G - G_c)^+ of every cluster,
    the eigenvalues of every G - G_c, ascending): what the jackknife's steps, their degrees
    of freedom and :func:`jackknife_defined` share. One stacked eigendecomposition of the
    symmetric G - G_c gives both the eigenvalues and the pseudo-inverse, V diag(1/w) V^T over
    |w| > 1e-15 max |w| (numpy's pinv(hermitian=True), its default cutoff), where pinv's SVD
    and eigvalsh took one decomposition each per cluster."""
    Js, scale = column_scaled(jac)
    Gc = _cluster_grams(Js, clusters)
    w, V = np.linalg.eigh(Js.T @ Js - Gc)
    big = np.abs(w) > 1e-15 * np.abs(w).max(axis=-1, initial=0.0, keepdims=True)
    inv = np.divide(1.0, w, out=np.zeros_like(w), where=big)
    return Js, scale, Gc, (V * inv[:, None, :]) @ np.swapaxes(V, -1, -2), w


def jackknife_steps(jac: np.ndarray, fun: np.ndarray, clusters: list[np.ndarray],
                    upstream: tuple[np.ndarray, np.ndarray] | None = None, *,
                    parts: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """The linearised change of each estimate when one cluster is left out, (C, k).

    Row c is d_c = (G - G_c)^+ (s_c - g - (J^T K - J_c^T K_c) u_c) + G^+ g, with G = J^T J,
    G_c = J_c^T J_c, s_c = J_c^T r_c, g = J^T r: the Gauss-Newton solution of the normal
    equations without cluster c less that with every cluster (exactly the refit's change for a
    linear model) when the coefficients an earlier fit fixed move by u_c as that fit leaves the
    same cluster out. At the optimum g = 0; the MF solves stop short of it (by a small
    fraction of a standard error at the noise stop, identify.fit.solve.engine.MF_SOLVE, by more
    where a solve crawling along a flat valley ends at its budget), and without g a cluster
    whose removal leaves a direction weakly determined turns that remainder into a step
    (G - G_c)^+ g that is no part of the estimate's variability. With g the steps are those
    of the optimum, wherever near it the solver stopped (exactly so for a linear model; on
    the ten generated TTC sessions of bench/ttc_truth.py the intervals came out the same to
    the printed digits, their solves ending close enough). ``upstream`` = (K, U): K = d r / d
    (the earlier coefficients), (n, m); U = their own steps per cluster, (C, m) (the rows of an
    earlier call, clusters in the same order; a cluster with no point here is an empty index
    array and still moves the estimate through u_c). Computed on the column-scaled J.
    ``parts``: :func:`_left_out` of ``jac`` and ``clusters`` when the caller has it.
    """
    Js, scale, _, A, _ = _left_out(jac, clusters) if parts is None else parts
    k = Js.shape[1]
    g = Js.T @ fun
    rhs = np.array([Js[i].T @ fun[i] for i in clusters]).reshape(len(clusters), k) - g
    if upstream is not None:
        K, U = (np.atleast_2d(np.asarray(a, dtype=float)) for a in upstream)
        JK = Js.T @ K
        rhs = rhs - np.array([(JK - Js[i].T @ K[i]) @ u for i, u in zip(clusters, U)]
                             ).reshape(rhs.shape)
    steps = np.einsum("cij,cj->ci", A, rhs).reshape(len(clusters), k)
    steps += np.linalg.pinv(Js.T @ Js, hermitian=True) @ g  # pinv's default cutoff, as A's
    return steps / scale


ESSENTIAL_RTOL = 1e-8
"""A cluster is essential (:func:`jackknife_defined`) when the smallest eigenvalue of the
column-scaled G - G_c falls below this fraction of G's."""


def jackknife_defined(jac: np.ndarray, clusters: list[np.ndarray]) -> bool:
    """False when one cluster alone determines a combination of the coefficients: without it
    the column-scaled normal matrix G - G_c is singular (its smallest eigenvalue below
    ESSENTIAL_RTOL x G's), e.g. the only sweep at one inflation pressure with the pressure
    terms free. The delete-one-cluster jackknife cannot see that cluster's noise (its step
    has no component along the direction it alone determines) and comes out too small there
    (a slope set by one of 12 clusters: 0.066 against a true sd of 0.257, the test of such a
    sweep in tests/unit/test_fit_engine.py); the covariance
    is then the iid one. True for a singular G (nothing to lose)."""
    return not clusters or not _essential(_left_out(jac, clusters))


def _essential(parts: tuple[np.ndarray, ...]) -> bool:
    """Some cluster is essential: the smallest eigenvalue of its column-scaled G - G_c below
    ESSENTIAL_RTOL x G's, G regular (``parts``: :func:`_left_out`, at least one cluster)."""
    Js, w = parts[0], parts[4]
    floor = ESSENTIAL_RTOL * np.linalg.eigvalsh(Js.T @ Js)[0]
    return bool(floor > 0 and not np.all(w[:, 0] >= floor))


def jackknife_covariance(steps: np.ndarray) -> np.ndarray:
    """The delete-one-cluster jackknife covariance (C - 1)/C sum_c d_c d_c^T of the C rows of
    ``steps`` (C, k) (:func:`jackknife_steps`)."""
    C = steps.shape[0]
    return (C - 1) / C * (steps.T @ steps)


def standard_errors(names: tuple[str, ...], cov: np.ndarray
                    ) -> tuple[dict[str, float], dict[str, float]]:
    """Standard errors ``{name: sd}`` and correlations ``{"a|b": r}`` (each pair once, in
    ``names`` order; NaN where a standard error is 0) of the covariance ``cov`` (k, k)."""
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    corr = {}
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            den = sd[i] * sd[j]
            corr[f"{names[i]}|{names[j]}"] = float(cov[i, j] / den) if den > 0 else float("nan")
    return {n: float(s) for n, s in zip(names, sd)}, corr


def covariance(jac: np.ndarray, fun: np.ndarray | None = None, *, sigma_known: bool = False,
               clusters: list[np.ndarray] | None = None, kind: str = "CR1",
               upstream: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Covariance of least-squares estimates from the Jacobian of the weighted residuals.

    Parameters
    ----------
    jac : ndarray
        d r / d x at the optimum, (n, k).
    fun : ndarray, optional
        The residuals r at the optimum (n,); needed unless ``sigma_known``.
    sigma_known : bool
        The weights are 1/sigma of each point: s^2 = 1. Otherwise s^2 = r^T r / max(n - k, 1).
    clusters : list of index arrays, optional
        Cluster-robust instead (``sigma_known`` is then ignored): residuals may be correlated
        and of any variance within a cluster (a sweep), independent between clusters. With
        G = J^T J, G_c = J_c^T J_c and s_c = J_c^T r_c over the C clusters:

        ``kind="CR1"``: the sandwich G^+ M G^+, M = C/(C - 1) sum_c s_c s_c^T;
        ``kind="jackknife"``: the delete-one-cluster jackknife (MacKinnon's CV3),
        (C - 1)/C sum_c d_c d_c^T with d_c = (G - G_c)^+ s_c, the Gauss-Newton step from the
        estimate to the one without cluster c. Larger than CR1 where one cluster pulls a
        coefficient: the small-cluster correction that keeps 95 % intervals near 95 % with
        tens of clusters (CR1 is too small there).
        Computed on the column-scaled J (k x k solves only; no n_c x n_c matrices;
        :func:`jackknife_steps`).
    kind : {"CR1", "jackknife"}
        See ``clusters``.
    upstream : (K, U), optional
        Jackknife only: the steps of coefficients an earlier fit fixed, so that their
        uncertainty enters (see :func:`jackknife_steps`).

    Returns
    -------
    ndarray (k, k)
    """
    J = np.atleast_2d(np.asarray(jac, dtype=float))
    n, k = J.shape
    if k == 0:
        return np.zeros((0, 0))
    if clusters and kind not in CLUSTER_KINDS:
        raise ValueError(f"kind must be one of {CLUSTER_KINDS}, not {kind!r}")
    if clusters and kind == "jackknife":
        return jackknife_covariance(jackknife_steps(J, fun, clusters, upstream))
    bread = pseudo_solve(J.T @ J, np.eye(k))
    if clusters:
        C = len(clusters)
        contrib = np.array([J[i].T @ fun[i] for i in clusters])
        return bread @ (C / max(C - 1, 1) * contrib.T @ contrib) @ bread
    s2 = 1.0 if sigma_known else float(fun @ fun) / max(n - k, 1)
    return s2 * bread


def jackknife_dof(jac: np.ndarray, clusters: list[np.ndarray], *,
                  parts: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """Degrees of freedom of each coefficient's delete-one-cluster jackknife variance, (k,).

    The jackknife variance of coefficient j is (C - 1)/C sum_c d_cj^2 (:func:`jackknife_steps`):
    a weighted sum of C squares, not a chi-square with C - 1 degrees of freedom. Where a few
    clusters carry a coefficient (PVX2 is set by the sweeps at the extreme loads; the pressure
    terms by the sweeps of the outer pressures) it rests on those few and varies far more
    between measurements than C - 1 suggests; value +/- 1.96 of it then holds the truth less
    often than 95 times in 100. Satterthwaite's approximation gives the degrees of freedom
    of such a sum, (sum_c l_cj)^2 / sum_c l_cj^2, with l_cj the variance of d_cj under a
    working model of independent residuals of one variance: l_c = diag(A_c G_c A_c), A_c =
    (G - G_c)^+, G_c = J_c^T J_c (the Bell-McCaffrey construction for the jackknife's steps).
    Equal weights give C; one cluster carrying everything gives 1. Capped at C - 1, floored
    at 1. Computed on the column-scaled J (the ratio does not depend on the scale).
    ``parts``: :func:`_left_out` of ``jac`` and ``clusters`` when the caller has it.
    """
    Js, _, Gc, A, _ = _left_out(jac, clusters) if parts is None else parts
    lam = np.einsum("cij,cjk,cki->ci", A, Gc, A).reshape(len(clusters), Js.shape[1])
    total, squares = lam.sum(axis=0), (lam ** 2).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        dof = np.where(squares > 0, total ** 2 / squares, len(clusters) - 1.0)
    return np.clip(dof, 1.0, max(len(clusters) - 1.0, 1.0))


def jackknife_with_dof(jac: np.ndarray, fun: np.ndarray, clusters: list[np.ndarray]
                       ) -> tuple[np.ndarray, np.ndarray] | None:
    """(:func:`covariance` with ``clusters`` and ``kind="jackknife"``, :func:`interval_dof`
    with the same), (k, k) and (k,), or None where :func:`jackknife_defined` is False: the
    three from one decomposition of every left-out normal matrix (:func:`_left_out`)."""
    J = np.atleast_2d(np.asarray(jac, dtype=float))
    if J.shape[1] == 0:
        return np.zeros((0, 0)), np.zeros(0)
    parts = _left_out(J, clusters)
    if clusters and _essential(parts):
        return None
    return (jackknife_covariance(jackknife_steps(J, fun, clusters, parts=parts)),
            jackknife_dof(J, clusters, parts=parts))


def interval_dof(jac: np.ndarray, *, sigma_known: bool = False,
                 clusters: list[np.ndarray] | None = None, kind: str = "CR1") -> np.ndarray:
    """Degrees of freedom of each coefficient's standard error from :func:`covariance` with the
    same arguments, (k,): the jackknife's per coefficient (:func:`jackknife_dof`); C - 1 for
    CR1 over C clusters; infinite with sigma known; n - k for iid (s^2 estimated from n - k
    residual degrees of freedom: exact for a model linear in its coefficients)."""
    J = np.atleast_2d(np.asarray(jac, dtype=float))
    n, k = J.shape
    if clusters and kind == "jackknife":
        return jackknife_dof(J, clusters)
    if clusters:
        return np.full(k, max(len(clusters) - 1.0, 1.0))
    return np.full(k, np.inf if sigma_known else max(n - k, 1.0))


def t_quantile(dof: float | np.ndarray, level: float = 0.95) -> float | np.ndarray:
    """The two-sided ``level`` quantile of Student's t with ``dof`` degrees of freedom: a
    ``level`` interval is value +/- t_quantile(dof) standard errors (1.959964 at dof = inf;
    2.045 at 29; 4.303 at 2). A NaN ``dof`` counts as infinite."""
    d = np.where(np.isnan(dof), np.inf, dof)
    q = stdtrit(d, 0.5 + 0.5 * level)
    return float(q) if np.ndim(q) == 0 else q
