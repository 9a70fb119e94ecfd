"""Identifiability screen of an MF stage: which candidate coefficients the data can determine.

Rules applied before the fit, so that a coefficient the data say nothing about is held (and
reported with the reason) instead of being "recovered" by luck or wandering to a bound:

1. Coverage (``identify.fit.mf.stage_data.Coverage``): a coefficient of a load-, pressure-, speed-,
   camber- or slip-sign-dependent term needs data that vary in that variable.
2. Sensitivity: the Jacobian of the weighted residuals at the start values (the problem's exact
   one when it has one, identify.fit.mf.jacobian; central differences otherwise).
   A coefficient with an exactly zero column (it multiplies a term that is zero at the start,
   e.g. QSX5..QSX9 while QSX4 = 0) is held; so is one whose unit-normalised column lies within
   ``DEPENDENCE_TOL`` of the span of the coefficients accepted before it (priority order of the
   stage), e.g. RBY3 when the combined data hold only two slip angles, and one whose unique
   effect is negligible (``EFFECT_TOL``) for a plausible change of the coefficient,
   max(|value|, |default|, DELTA_FLOOR / m). m is the largest magnitude of the monomial the
   coefficient multiplies (identify.fit.mf.stage_specs.TERMS: gamma^2 for PEY5, |gamma| for
   PKY3, dfz for PDY2, dpi gamma for PPY5, 1 for a zero-order one) over the stage's points, or
   its value at the REFERENCE extent (|gamma| 0.1 rad, |dfz| 0.5, |dpi| 0.25) when that is
   larger: the floor moves the coefficient's factor by DELTA_FLOOR at the larger extreme. So
   PEY5 at 0 on data with 0..4 deg camber has the plausible change 1 (a fixed 0.01 moved
   Ey by 5e-5 at 4 deg and held it, though the golden test tyre's PEY5 = 300 adds 1.46 there),
   while on data within +-0.3 deg, where the same change moves Ey by 3e-5 at most, it stays
   negligible (tests/unit/test_fit_mf_screen.py).

After the stage's global fit (identify.fit.mf.stages):

3. Gates: rule 2 again, at the start values moved by the coefficients that have significantly
   moved (``Z_GATE`` standard errors): a coefficient that had no effect only because another
   one was 0 at the start (PEX4 while PEX1..3 = 0, the MFeval defaults; PPMX1 while QSX2 = 0)
   is freed, and the stage is re-fitted locally from its optimum. A gate that moved only
   within the noise (QSX7, QSX8 of a tyre without that Mx term) frees nothing, so no product
   of two unidentifiable coefficients is left to wander. The re-fit is kept only when it
   lowers chi^2 (on the scale of the stage's intervals) by more than the 95 % quantile of
   chi^2 with one degree of freedom per freed coefficient: a gate that moved by chance (about
   one stage in ten with three coefficients at 2 standard errors) would otherwise free a shape
   that the re-fit fits to the noise (tests/unit/test_fit_mf_after_fit_gain.py).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from identify.fit.mf.stage_specs import TERMS
from identify.fit.solve.engine import fd_jacobian
from identify.fit.solve.problem import FitProblem
from identify.model.parameters import spec
from identify.model.state import OperatingState

DEPENDENCE_TOL = 1e-5
"""Relative residual of a unit-normalised Jacobian column after projection on the accepted
columns below which a coefficient counts as not separable. Central differences with a
relative step of 1e-6 resolve exact dependence to ~1e-9."""
EFFECT_TOL = 1e-6
"""Unique effect below which a coefficient counts as negligible: the norm of the projected
column times the coefficient's plausible change max(|value|, |default|, DELTA_FLOOR / m) (m:
:func:`term_magnitudes`), in units of the weighted residuals (the root sum over pressures of
squared thesis errors / 100), i.e. a plausible change moves the fit by less than 1e-4 %."""
Z_GATE = 2.0
"""A fitted coefficient has significantly moved from its start value when
|value - start| >= Z_GATE standard errors (rule 3)."""
DELTA_FLOOR = 0.01
"""Smallest plausible change of the factor a coefficient's term adds to (for one whose value
and default are 0): the coefficient's own change for a zero-order one, DELTA_FLOOR / m for one
that multiplies a monomial of largest magnitude m (:func:`term_magnitudes`)."""
REFERENCE = {"gamma": 0.1, "dfz": 0.5, "dpi": 0.25}
"""The extent over which a tyre's camber, load and pressure terms act in the usual tests:
|gamma| [rad] 0.1 (5.7 deg; a camber sweep's 4..6 deg), |dfz| 0.5 (0.5..1.5 Fz0), |dpi|
0.25 (a +-25 % pressure range). A monomial's magnitude m is at least its value here, so
that the plausible change of a coefficient does not grow without bound when the data's
variable barely varies: PEY5 (on gamma^2) on data within +-0.3 deg moves Ey by
DELTA_FLOOR (0.3 deg / 5.7 deg)^2 = 3e-5 and stays negligible, as on data without camber."""
MONOMIALS = {"Q_FZ2": 0.01}
"""The magnitude m of a monomial that is not a state variable (term_magnitudes): Q_FZ2
multiplies (rho/R0)^2 in the load law, about 0.01 at 1.5 Fz0 (rho/R0 ~ 0.06 at Fz0 for the
bundled tyre and the golden test tyre), so its plausible change is 1 (a tenth of Q_FZ1 ~ 15).
With the zero-order 0.01 the screen held it at its floor 1e-4 on the golden MF 6.2 tyre's
loaded radius (effect 6.7e-7, tests/integration/test_fit_mf_vertical.py)."""
STEP = 1e-6
"""Relative step of the central differences (identify.fit.solve.engine.fd_jacobian) when the problem
has no exact Jacobian: of max(|value|, STEP_FLOOR)."""
STEP_FLOOR = 1e-3
"""Smallest magnitude the relative STEP is taken of (a coefficient at 0 steps by 1e-9)."""


def dependence(J: np.ndarray, names: Sequence[str], delta: np.ndarray | None = None,
               tol: float = DEPENDENCE_TOL, effect_tol: float = EFFECT_TOL
               ) -> tuple[dict[str, str], dict[str, float]]:
    """Gram-Schmidt in priority order over the columns of ``J``.

    Parameters
    ----------
    J : ndarray (points, coefficients)
    names : sequence of str      column names, priority order
    delta : ndarray, optional    plausible change of each coefficient (default 1)

    Returns
    -------
    held : dict name -> reason
    residual : dict name -> relative residual of the column after projection (1 = orthogonal)
    """
    delta = np.ones(len(names)) if delta is None else np.asarray(delta, dtype=float)
    held: dict[str, str] = {}
    residual: dict[str, float] = {}
    # the accepted orthonormal columns, filled in order (classical Gram-Schmidt, twice: as
    # accurate as the modified one re-orthogonalised, in two matrix products per pass)
    basis = np.empty((J.shape[0], len(names)), order="F")
    accepted: list[str] = []
    for j, name in enumerate(names):
        col = J[:, j]
        norm = float(np.linalg.norm(col))
        if not np.isfinite(norm):
            held[name] = "sensitivity: not finite at the start values"
            continue
        if norm == 0.0:
            held[name] = "sensitivity: no effect on the data at the start values"
            residual[name] = 0.0
            continue
        v = col / norm
        Q = basis[:, :len(accepted)]
        coef = np.zeros(len(accepted))
        for _ in range(2):  # re-orthogonalise once for accuracy
            c = v @ Q
            v = v - Q @ c
            coef += c
        rel = float(np.linalg.norm(v))
        residual[name] = rel
        if rel < tol:
            top = [accepted[i] for i in np.argsort(np.abs(coef))[::-1][:3]]
            held[name] = (f"sensitivity: not separable from {', '.join(top)} "
                          f"(residual {rel:.1e})")
            continue
        effect = rel * norm * delta[j]
        if effect < effect_tol:
            held[name] = (f"sensitivity: negligible effect ({effect:.1e} for a change of "
                          f"{delta[j]:.3g})")
            continue
        basis[:, len(accepted)] = v / rel
        accepted.append(name)
    return held, residual


def term_magnitudes(names: Sequence[str], s: OperatingState) -> np.ndarray:
    """The magnitude m of the monomial each coefficient multiplies (identify.fit.mf.stage_specs
    TERMS: gamma^2 for PEY5, dfz gamma for PKY7, dpi for PPY1, ...): its largest |value| over
    the points ``s``, or at the REFERENCE extent if that is larger; MONOMIALS' value for the
    load law's Q_FZ2; 1 for a zero-order coefficient.

    Parameters
    ----------
    names : sequence of str
    s : OperatingState   the stage's points (gamma [rad], dfz [-], dpi [-])

    Returns
    -------
    ndarray [-], one per name
    """
    out = np.ones(len(names))
    for j, name in enumerate(names):
        if name in MONOMIALS:
            out[j] = MONOMIALS[name]
            continue
        powers = TERMS.get(name)
        if not powers:
            continue
        term = np.ones_like(s.dfz, dtype=float)
        ref = 1.0
        for var, k in powers.items():
            term = term * np.abs(getattr(s, var)) ** k
            ref *= REFERENCE[var] ** k
        out[j] = max(float(np.max(term, initial=0.0)), ref)
    return out


def screen(problem: FitProblem, tol: float = DEPENDENCE_TOL,
           magnitudes: np.ndarray | None = None
           ) -> tuple[dict[str, str], dict[str, float]]:
    """Sensitivity rule for the free parameters of ``problem`` (declaration order = priority).

    Parameters
    ----------
    problem : FitProblem
    tol : float          DEPENDENCE_TOL
    magnitudes : ndarray, optional
        :func:`term_magnitudes` of ``problem.free`` at its points (default 1: every
        coefficient zero-order).

    Returns
    -------
    held : dict name -> reason
    residual : dict name -> relative residual (see :func:`dependence`)
    """
    free = problem.free
    x0 = problem.x0()
    J = problem.residual_jacobian(x0)
    if J is None:  # central differences, steps not clipped at the bounds
        J = fd_jacobian(problem.residuals, x0, rel_step=STEP, floor=STEP_FLOOR)
    m = np.ones(len(free)) if magnitudes is None else np.asarray(magnitudes, dtype=float)
    delta = np.array([max(abs(x), abs(float(spec(n).default)), DELTA_FLOOR / mj)
                      for n, x, mj in zip(free, x0, m)])
    return dependence(J, free, delta, tol)
