"""Projected score (Lagrange-multiplier) tests of candidate effects, from the base fit alone.

For candidate k with residual-derivative columns G_k = d r / d c_k at the neutral value
(n x q; q = 1 for one coefficient, a block otherwise) and J the Jacobian of the fitted
parameters, the part of G_k the fitted parameters cannot already explain is

    G~_k = M G_k,     M = I - J (J^T J)^+ J^T,

and with s_k = G~_k^T r (r: the base residuals, prewhitened where the noise is AR(1)) the score
is the properly scaled gradient of the objective at the neutral value:

    D_k = s_k^T (G~_k^T G~_k)^-1 s_k          one-step drop of the residual sum of squares
    independent / AR(1):  LM_k = D_k / sigma^2,
                          F_k = (D_k / q) / ((r^T r - D_k) / (n - p - q))   ~ F(q, n - p - q)
    cluster-robust:       W_k = s_k^T V_k^-1 s_k / q (d - q + 1) / d,   ~ F(q, d - q + 1)
                          V_k = sum_c e_kc e_kc^T, e_kc = G~_kc^T r_c - A_kc d_k(c): sweep
                          c's score centred at the one-step estimate d_k(c) of the other
                          sweeps; d: Satterthwaite degrees of freedom of V_k, the number of
                          sweeps that effectively carry the candidate
                          (:func:`left_out_score_variance`)
    cluster, pooled:      F_k = s_k^2 / (kappa A_k),  ~ F(1, d_h)     (a pressure candidate,
                          where d_h > d)
                          kappa = sum_c (H_c^T r_c)^2 / sum_c H_c^T H_c over the control
                          sweeps (those at the nominal pressure, where the candidate's column
                          vanishes): the variance per unit norm of a sweep's score along the
                          candidate's shape H (its column at one common pressure for every
                          point); d_h: Satterthwaite degrees of freedom of that pooled sum
                          (:func:`pooled_score_variance`)

The statistic used is the one-step F form of the LM test (sigma^2 estimated with the candidate
added in one Gauss-Newton step): asymptotically the chi^2(q) LM test, and exact for linear
models, so small characteristic tables keep their power. Testability: ||G~_k|| / ||G_k|| (a
block: its smallest singular value ratio); ambiguity: the largest canonical correlation
between the projected column spaces of two candidates, grouped when above the threshold.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special, stats

from identify.discover.noise import Sweeps
from identify.fit.solve.engine import pseudo_solve

__all__ = ["Score", "project_basis", "score_candidates", "left_out_score_variance",
           "pooled_score_variance",
           "canonical_cosines", "CONTROL_SHARE", "MIN_CONTROLS",
           "ambiguity_groups", "holm", "TESTABLE_REL_NORM", "AMBIGUITY_COS"]

TESTABLE_REL_NORM = 1e-3
"""A candidate whose projected column keeps less than this fraction of its norm is untestable."""
AMBIGUITY_COS = 0.95
"""|cos| above which two candidates form an ambiguity group."""
CONTROL_SHARE = 0.01
"""A sweep is a control of a pressure candidate when its column, per unit norm of the shape,
holds less than this share of the largest sweep's (linear in dpi: |dpi| below a tenth of the
farthest level's)."""
MIN_CONTROLS = 10
"""Fewest control sweeps for the pooled variance (else the sweep-robust one)."""


@dataclass(frozen=True)
class Score:
    """The score test of one candidate on one problem.

    Attributes
    ----------
    dof : int              number of coefficients (q)
    statistic : float      one-step F (LM) or cluster-robust Wald/q, both ~ F
    p_value, log_p : float
    rel_norm : float       ||M G|| / ||G|| (smallest over a block) [-]
    testable : bool
    drop : float           predicted drop of the (weighted, prewhitened) residual sum of squares
    step : tuple of float  one-step Gauss-Newton change of the coefficients from neutral
    """

    dof: int
    statistic: float
    p_value: float
    log_p: float
    rel_norm: float
    testable: bool
    drop: float
    step: tuple[float, ...]


def project_basis(J: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space of J (rank-revealing SVD)."""
    if J.size == 0:
        return np.zeros((J.shape[0], 0))
    U, s, _ = np.linalg.svd(J, full_matrices=False)
    keep = s > s[0] * 1e-10 if s.size and s[0] > 0 else np.zeros(0, dtype=bool)
    return U[:, keep]


def _project(Q: np.ndarray, G: np.ndarray) -> np.ndarray:
    return G - Q @ (Q.T @ G) if Q.shape[1] else G.copy()


def score_candidates(r: np.ndarray, J: np.ndarray, columns: dict[str, np.ndarray], *,
                     kind: str = "independent", clusters=None,
                     shapes: dict[str, np.ndarray] | None = None,
                     ) -> tuple[dict[str, Score], dict[str, np.ndarray]]:
    """Score every candidate.

    Parameters
    ----------
    r : (n,) residuals at the base optimum (transformed like J and the columns)
    J : (n, p) Jacobian of the free parameters
    columns : name -> (n, q) candidate columns
    kind : ``"independent"``, ``"ar1"`` (already prewhitened) or ``"cluster"``
    clusters : Sweeps (or index arrays) of the sweeps (``"cluster"`` only)
    shapes : name -> (n,) shape column of a one-coefficient pressure candidate: its column
        with every point at one common pressure (transformed like the columns). With
        ``"cluster"`` such a candidate's score variance is pooled over the control sweeps
        (:func:`pooled_score_variance`) where that estimate has more degrees of freedom than
        the sweep-robust one, which rests on the sweeps that carry the candidate.

    Returns
    -------
    scores : name -> Score
    projected : name -> (n, q) projected columns (for cosines)
    """
    n, p = J.shape
    Q = project_basis(J)
    if clusters is not None:
        clusters = Sweeps.of(clusters, n)
    scores, projected = {}, {}
    for name, G in columns.items():
        G = G.reshape(n, -1)
        q = G.shape[1]
        Gt = _project(Q, G)
        projected[name] = Gt
        if q == 1:
            norm = float(np.linalg.norm(G))
            rel = float(np.linalg.norm(Gt)) / norm if norm > 0 else 0.0
        else:
            sv_full = np.linalg.svd(G, compute_uv=False)
            sv_proj = np.linalg.svd(Gt, compute_uv=False)
            rel = float(sv_proj.min() / sv_full.max()) if sv_full.max() > 0 else 0.0
        testable = rel >= TESTABLE_REL_NORM and np.all(np.isfinite(Gt))
        if not testable:
            scores[name] = Score(q, float("nan"), 1.0, 0.0, rel, False, 0.0, (0.0,) * q)
            continue
        s = Gt.T @ r
        A = Gt.T @ Gt
        z = pseudo_solve(A, s)
        drop = float(s @ z)
        step = tuple(float(v) for v in -z)
        shape = (shapes or {}).get(name)
        pooled = (pooled_score_variance(np.asarray(shape, dtype=float).reshape(n), r, clusters,
                                        G[:, 0], Q)
                  if shape is not None and q == 1 and kind == "cluster"
                  and clusters is not None and len(clusters) else None)
        if kind == "cluster" and clusters is not None and len(clusters):
            V, d = left_out_score_variance(Gt, r, clusters, A)
            # Hotelling's small-sample form for a q x q variance with d degrees of freedom
            d2 = max(d - q + 1.0, 1.0)
            stat = float(s @ pseudo_solve(V, s)) / q * d2 / d
            log_p = _log_sf("f", stat, q, d2)
            if pooled is not None and pooled[1] > d:
                # the variance estimate with more degrees of freedom: a choice made from the
                # design (which sweeps hold the column and the shape), not from the residuals
                kappa, d = pooled
                stat = float(s[0] ** 2 / (kappa * A[0, 0]))
                log_p = _log_sf("f", stat, 1, d)
        else:
            dof = max(n - Q.shape[1] - q, 1)
            rest = max(float(r @ r) - drop, 1e-300)
            stat = (drop / q) / (rest / dof)
            log_p = _log_sf("f", stat, q, dof)
        scores[name] = Score(q, stat, float(np.exp(log_p)), log_p, rel, True, drop, step)
    return scores, projected


def left_out_score_variance(Gt: np.ndarray, r: np.ndarray, clusters: Sweeps,
                            A: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Cluster-robust variance of the score s = G~^T r from the sweeps' own contributions,
    each centred at the one-step estimate of the sweeps without it, (q, q).

    With s_c = G~_c^T r_c and A_c = G~_c^T G~_c of sweep c, A = G~^T G~, and the one-step
    estimate of the other sweeps d_(c) = (A - A_c)^+ (s - s_c), the contribution of sweep c
    is its prediction residual e_c = s_c - A_c d_(c), and V = sum_c e_c e_c^T: the
    delete-one-sweep jackknife (MacKinnon's CV3) of the one-step estimate, expressed on the
    score (s^T V^+ s is the Wald statistic of that estimate with its jackknife covariance
    A^+ V A^+).

    Why centred: the uncentred sum of s_c s_c^T holds the effect itself whenever the
    candidate is missing. Where a few sweeps carry it (a pressure law seen in the two or
    three sweeps at each off-nominal pressure) their contributions are the score: W =
    (sum s_c)^2 / sum s_c^2 is then at most about the number of those sweeps however strong
    and consistent the effect, and a pressure law that every sweep at every pressure agrees on
    stayed untested. The independent-noise F form takes its sigma^2 with the candidate added
    (one step) for the same reason. Leaving the sweep out of its own centring keeps the
    variance from shrinking where one sweep pulls the estimate: a sweep that alone carries a
    direction (A - A_c singular there) keeps its uncentred contribution along it.

    Degrees of freedom: V is a weighted sum of C squares, not a chi-square with C - 1 degrees
    of freedom. Where a few sweeps carry the candidate (a pressure law: the sweeps at the
    off-nominal pressures, the high loads most) V rests on those few and W referred to
    F(q, C - 1) rejects a true null far more often than its level. Satterthwaite's
    approximation under a working model of independent residuals of one variance gives the
    degrees of freedom d of each coefficient's variance, (sum_c l_c)^2 / sum_c l_c^2 with
    l_c = diag((A - A_c)^+ A_c (A - A_c)^+) (the Bell-McCaffrey construction the fit's
    jackknife intervals use); the smallest over the block is returned, in [1, C - 1].

    Returns
    -------
    V : ndarray (q, q)
    dof : float
    """
    q = Gt.shape[1]
    C = len(clusters)
    s_c = clusters.sums(Gt * r[:, None]).reshape(-1, q)  # (C, q): per-sweep scores
    outer = (Gt[:, :, None] * Gt[:, None, :]).reshape(Gt.shape[0], q * q)
    A_c = clusters.sums(outer).reshape(-1, q, q)
    A = Gt.T @ Gt if A is None else A
    s = Gt.T @ r
    w, U = np.linalg.eigh(A[None] - A_c)
    big = w > 1e-10 * max(float(np.linalg.eigvalsh(A)[-1]), 1e-300)
    inv = np.divide(1.0, w, out=np.zeros_like(w), where=big)
    R = np.einsum("cij,cj,ckj->cik", U, inv, U)  # (A - A_c)^+
    d = np.einsum("cij,cj->ci", R, s[None] - s_c)
    e = s_c - np.einsum("cij,cj->ci", A_c, d)
    # Satterthwaite on V's diagonal under a working model of independent residuals of one
    # variance (Bell and McCaffrey; identify.fit.solve.covariance.jackknife_dof for the
    # fit's intervals): the variance of e_c is then about the leverage-inflated A_c
    lam = np.einsum("cij,cjk,cki->ci", R, A_c, R).reshape(C, q)
    total, squares = lam.sum(axis=0), (lam ** 2).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        dof = np.where(squares > 0, total ** 2 / squares, C - 1.0)
    return e.T @ e, float(np.clip(dof.min(), 1.0, max(C - 1.0, 1.0)))


def pooled_score_variance(H: np.ndarray, r: np.ndarray, clusters: Sweeps,
                          G: np.ndarray | None = None, Q: np.ndarray | None = None
                          ) -> tuple[float, float] | None:
    """Variance per unit norm of a sweep's score along a candidate's shape, pooled over the
    control sweeps, and its degrees of freedom; None without :data:`MIN_CONTROLS` controls.

    A pressure candidate's column G is its shape H times a power of dpi: zero on the sweeps at
    the nominal pressure. In the usual trailer session most sweeps run at the nominal
    pressure and two or three at each other one, so the sweep-robust variance
    (:func:`left_out_score_variance`) rests on those few sweeps and its degrees of freedom
    fall to about three, whatever the effect's size and consistency. The nominal sweeps still
    say how far a sweep's own misfit (its shape error, its offset, its correlated noise) leans
    along H when pressure plays no part: with each control sweep's score h_c = H_c^T r_c,
    norm a_c = H_c^T H_c and the part l_c = ||Q_c^T H_c||^2 of it that the base fit's
    projection takes (Q: orthonormal basis of the fitted parameters' columns),

        kappa = sum_c h_c^2 / sum_c (a_c - l_c),      Var(G~^T r) = kappa G~^T G~,

    the variance of the candidate's score when every sweep's misfit along its shape has the
    same size per unit norm, whatever its pressure: the control-group argument of inference
    with few treated clusters. The residuals are those of the base fit, r = M e, so
    E h_c^2 = sigma^2 (a_c - l_c) for independent errors of variance sigma^2: without l_c
    kappa would come short by about the share of the fitted parameters in the sweeps'
    degrees of freedom, and the test would reject a true null above its level. Controls are
    the sweeps whose column per unit norm of the shape, G_c^T G_c / a_c, is below
    :data:`CONTROL_SHARE` of the largest sweep's; the sweeps that carry the candidate are left
    out, since their h_c would hold the effect itself (a session at two pressures, half its
    sweeps off the nominal one, would lose most of its power with them). Without G every sweep
    is a control. The shape is not projected on the fitted parameters' complement: at one
    pressure a pressure coefficient's shape is a base coefficient's column (PPY3's is PDY1's,
    PPY1's PKY1's), which the projection would remove whole. Degrees of freedom:
    Satterthwaite's for a sum of squares weighted by a_c - l_c,
    (sum (a_c - l_c))^2 / sum (a_c - l_c)^2, the number of control sweeps that effectively
    hold the shape.

    Parameters
    ----------
    H : (n,) shape column (prewhitened like the residuals, not projected)
    r : (n,) residuals of the base fit
    clusters : Sweeps
    G : (n,) the candidate's column (unprojected), to tell the controls
    Q : (n, p) orthonormal basis of the fitted parameters' columns (:func:`project_basis`);
        None: no correction for the base fit

    Returns
    -------
    (kappa, dof) or None
    """
    h_c = np.asarray(clusters.sums(H * r), dtype=float).ravel()
    a_c = np.asarray(clusters.sums(H * H), dtype=float).ravel()
    control = a_c > 0
    if G is not None:
        g_c = np.asarray(clusters.sums(G * G), dtype=float).ravel()
        ratio = np.divide(g_c, a_c, out=np.full_like(g_c, np.inf), where=control)
        control &= ratio <= CONTROL_SHARE * float(ratio[a_c > 0].max(initial=0.0))
    if control.sum() < MIN_CONTROLS:
        return None
    w_c = a_c.copy()
    if Q is not None and Q.shape[1]:
        b = np.asarray(clusters.sums(Q * H[:, None]), dtype=float).reshape(-1, Q.shape[1])
        w_c = np.maximum(a_c - np.einsum("cj,cj->c", b, b), 0.0)
    h_c, w_c = h_c[control], w_c[control]
    if not w_c.sum() > 0:
        return None
    kappa = float(h_c @ h_c) / float(w_c.sum())
    if not kappa > 0:
        return None
    return kappa, float(w_c.sum()) ** 2 / float(w_c @ w_c)


def _log_sf(dist: str, x: float, d1: int, d2: int = 1) -> float:
    """log of the upper tail of chi^2(d1) or F(d1, d2) at x (cheap special functions; the
    scipy.stats route only where the tail underflows)."""
    p = special.chdtrc(d1, x) if dist == "chi2" else special.fdtrc(d1, d2, x)
    if p > 1e-280:
        return float(np.log(p))
    law = stats.chi2(d1) if dist == "chi2" else stats.f(d1, d2)
    return float(law.logsf(x))


def canonical_cosines(projected: dict[str, np.ndarray]) -> dict[tuple[str, str], float]:
    """|cos| (largest canonical correlation) between every pair of projected candidates."""
    bases = {}
    for name, G in projected.items():
        U, s, _ = np.linalg.svd(G, full_matrices=False)
        bases[name] = U[:, s > (s[0] * 1e-8 if s.size and s[0] > 0 else np.inf)]
    names = list(bases)
    out = {}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if bases[a].shape[1] == 0 or bases[b].shape[1] == 0:
                c = 0.0
            else:
                c = float(np.linalg.svd(bases[a].T @ bases[b], compute_uv=False).max())
            out[(a, b)] = out[(b, a)] = min(c, 1.0)
    return out


def ambiguity_groups(names: list[str], cos: dict[tuple[str, str], float],
                     threshold: float = AMBIGUITY_COS) -> list[tuple[str, ...]]:
    """Connected groups (two or more names) of candidates with |cos| > threshold."""
    parent = {n: n for n in names}

    def root(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if cos.get((a, b), 0.0) > threshold:
                parent[root(a)] = root(b)
    groups: dict[str, list[str]] = {}
    for n in names:
        groups.setdefault(root(n), []).append(n)
    return [tuple(g) for g in groups.values() if len(g) > 1]


def holm(p_values: dict[str, float]) -> dict[str, float]:
    """Holm-adjusted p-values (step-down, monotone)."""
    order = sorted(p_values, key=lambda k: p_values[k])
    m = len(order)
    out, running = {}, 0.0
    for i, k in enumerate(order):
        running = max(running, min(1.0, (m - i) * p_values[k]))
        out[k] = running
    return out
