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
    cluster-robust:       W_k = s_k^T V_k^-1 s_k / q,  V_k = C/(C-1) sum_c (G~_kc^T r_c)(...)^T
                                                                         ~ F(q, C - 1)

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

__all__ = ["Score", "project_basis", "score_candidates", "canonical_cosines",
           "ambiguity_groups", "holm", "TESTABLE_REL_NORM", "AMBIGUITY_COS"]

TESTABLE_REL_NORM = 1e-3
"""A candidate whose projected column keeps less than this fraction of its norm is untestable."""
AMBIGUITY_COS = 0.95
"""|cos| above which two candidates form an ambiguity group."""


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
                     ) -> tuple[dict[str, Score], dict[str, np.ndarray]]:
    """Score every candidate.

    Parameters
    ----------
    r : (n,) residuals at the base optimum (transformed like J and the columns)
    J : (n, p) Jacobian of the free parameters
    columns : name -> (n, q) candidate columns
    kind : ``"independent"``, ``"ar1"`` (already prewhitened) or ``"cluster"``
    clusters : Sweeps (or index arrays) of the sweeps (``"cluster"`` only)

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
        if kind == "cluster" and clusters is not None and len(clusters):
            C = len(clusters)
            contrib = clusters.sums(Gt * r[:, None])  # (C, q): per-sweep scores
            V = C / max(C - 1, 1) * (contrib.T @ contrib)
            stat = float(s @ pseudo_solve(V, s)) / q
            log_p = _log_sf("f", stat, q, max(C - 1, 1))
        else:
            dof = max(n - Q.shape[1] - q, 1)
            rest = max(float(r @ r) - drop, 1e-300)
            stat = (drop / q) / (rest / dof)
            log_p = _log_sf("f", stat, q, dof)
        scores[name] = Score(q, stat, float(np.exp(log_p)), log_p, rel, True, drop, step)
    return scores, projected


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
