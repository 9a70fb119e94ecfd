"""Validity constraints of Magic Formula coefficients (MFeval's ``coefficientCheck``).

MFeval's ``coefficientCheck`` conditions, as :class:`~identify.fit.solve.problem.Constraint` objects
(``g(values) >= 0``) for the MF fitting stages:

=======  ==========================================================================
stage    conditions
=======  ==========================================================================
Fx0      Cx > 0, Dx > 0, Ex <= 1
Fy0      Cy > 0, Dy > 0 (mfid's addition, the lateral twin of Dx > 0), Ey <= 1
Mz0      Bt > 0, Ct > 0, Et <= 1
Fx       Bx_alpha > 0, Ex_alpha <= 1, Gx_alpha > 0   (only when RBX1 or RBX3 != 0)
Fy       By_kappa > 0, Ey_kappa <= 1, Gy_kappa > 0   (only when RBY1, RBY3 or RBY4 != 0)
=======  ==========================================================================

Each condition is evaluated on the 11-point grid between the .tir limits of the variables it
depends on: Fz in [FZMIN, FZMAX] (from 1 N when FZMIN = 0), kappa in [KPUMIN, KPUMAX], alpha in
[ALPMIN, ALPMAX], gamma in [CAMMIN, CAMMAX], and at the inflation pressures present in the data.
Quantities even in gamma (Bx_alpha, Gx_alpha, By_kappa, Gy_kappa) use the grid's distinct
|gamma| values, which gives the same set of values. Evaluation uses useMode 211 (no clipping,
so E is never hidden by the E <= 1 clip). A constraint returns, for each of the 11 grid loads,
the minimum over the other grid axes of its margin (so an optimiser sees 11 values per
condition instead of thousands).

The conditions hold over whatever limits ``base`` carries. The MF stages give them the limits
the written .tir states: the trailer data's ranges widened to the other fitted points'
(identify.fit.mf.stages.fit_mf ``reach``, identify.fit.limits). Over MFeval's defaults
(ALPMIN/ALPMAX = -/+1.5 rad, KPUMIN/KPUMAX = -/+1.5), far beyond any sweep, Gx_alpha > 0 and
Gy_kappa > 0 bind RCX1 and RCY1 near 1, below the 1.05 of tyres that meet them over every slip
a sweep reaches. :func:`violations` checks a written file over its own limits.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from identify.fit.mf.stage_specs import subset_state
from identify.fit.solve.engine import FEASIBLE_TOL, violation
from identify.fit.solve.problem import Constraint
from identify.model import lateral, longitudinal
from identify.model.longitudinal import magic_cosine
from identify.model.modes import FIT_MODE
from identify.model.state import OperatingState, prepare, sgn1

GRID_POINTS = 11
CONSTRAINED_STAGES = ("Fx0", "Fy0", "Mz0", "Fx", "Fy")
"""The stages with validity conditions (the table above; :func:`stage_constraints` gives the
others none)."""


@dataclass(frozen=True)
class ValidityGrid:
    """The axes of the coefficient-check grid.

    Attributes
    ----------
    fz : ndarray [N]        11 loads from max(FZMIN, 1 N if FZMIN = 0) to FZMAX
    kappa : ndarray [-]     11 slips from KPUMIN to KPUMAX
    alpha : ndarray [rad]   11 slip angles from ALPMIN to ALPMAX
    gamma : ndarray [rad]   11 inclination angles from CAMMIN to CAMMAX
    p : ndarray [Pa]        the pressures present in the data
    """

    fz: np.ndarray
    kappa: np.ndarray
    alpha: np.ndarray
    gamma: np.ndarray
    p: np.ndarray


def validity_grid(P: Mapping[str, float], pressures: Sequence[float]) -> ValidityGrid:
    """The coefficient-check grid for the .tir limits in ``P`` and the data's ``pressures`` [Pa]."""
    n = GRID_POINTS
    fzmin = float(P["FZMIN"]) if float(P["FZMIN"]) > 0 else 1.0
    p = np.unique(np.asarray(pressures, dtype=float))
    if p.size == 0:
        p = np.array([float(P["INFLPRES"])])
    return ValidityGrid(fz=np.linspace(fzmin, float(P["FZMAX"]), n),
                        kappa=np.linspace(float(P["KPUMIN"]), float(P["KPUMAX"]), n),
                        alpha=np.linspace(float(P["ALPMIN"]), float(P["ALPMAX"]), n),
                        gamma=np.linspace(float(P["CAMMIN"]), float(P["CAMMAX"]), n),
                        p=p)


def _state(P: Mapping[str, float], grid: ValidityGrid, axes: Sequence[str]) -> OperatingState:
    """Operating points on the product of Fz (first axis) and ``axes``, flattened so that the
    load index is the slowest: reshape(11, -1) groups the points by grid load."""
    names = ("fz",) + tuple(axes)
    # "gamma_abs": the distinct |gamma| of the grid, for quantities even in gamma
    axis = {a: (np.unique(np.abs(grid.gamma)) if a == "gamma_abs" else getattr(grid, a))
            for a in names}
    mesh = np.meshgrid(*(axis[a] for a in names), indexing="ij")
    col = {a.replace("_abs", ""): m.ravel() for a, m in zip(names, mesh)}
    zeros = np.zeros(col["fz"].size)
    return prepare(P, col["fz"], col.get("kappa", zeros), col.get("alpha", zeros),
                   col.get("gamma", zeros), np.full(zeros.size, float(P["LONGVL"])),
                   p=col.get("p", np.full(zeros.size, float(grid.p[0]))), mode=FIT_MODE)


def _per_load(values: np.ndarray) -> np.ndarray:
    """Minimum over all grid axes but the load (shape (11,); (W, 11) for walker arrays)."""
    v = np.asarray(values, dtype=float)
    return v.reshape(v.shape[:-1] + (GRID_POINTS, -1)).min(axis=-1)


# ----- the derived quantities (formulas of docs/model.md, sections 4-6) ----------------------

def _ex(P, s):
    kx = s.kappa + (P["PHX1"] + P["PHX2"] * s.dfz) * P["LHX"] * s.ws
    return ((P["PEX1"] + P["PEX2"] * s.dfz + P["PEX3"] * s.dfz ** 2)
            * (1 - P["PEX4"] * np.sign(kx)) * P["LEX"])


def _ey(P, s, pure: lateral.PureLateral):
    g = s.gamma_star
    alpha_y = s.alpha_star + pure.shy
    return ((P["PEY1"] + P["PEY2"] * s.dfz)
            * (1 + P["PEY5"] * g ** 2 - (P["PEY3"] + P["PEY4"] * g) * sgn1(alpha_y)) * P["LEY"])


def _bt(P, s):
    return ((P["QBZ1"] + P["QBZ2"] * s.dfz + P["QBZ3"] * s.dfz ** 2)
            * (1 + P["QBZ4"] * s.gamma + P["QBZ5"] * np.abs(s.gamma)) * P["LKY"] / P["LMUY"])


def _et(P, s):
    g = s.gamma_star
    alpha_t = s.alpha_star + P["QHZ1"] + P["QHZ2"] * s.dfz + (P["QHZ3"] + P["QHZ4"] * s.dfz) * g
    return ((P["QEZ1"] + P["QEZ2"] * s.dfz + P["QEZ3"] * s.dfz ** 2)
            * (1 + (P["QEZ4"] + P["QEZ5"] * g) * (2 / np.pi)
               * np.arctan(_bt(P, s) * P["QCZ1"] * alpha_t)))


def _bxa(P, s):
    return ((P["RBX1"] + P["RBX3"] * s.gamma_star ** 2)
            * np.cos(np.arctan(P["RBX2"] * s.kappa)) * P["LXAL"])


def _byk(P, s):
    g, a = s.gamma_star, s.alpha_star
    return ((P["RBY1"] + P["RBY4"] * g ** 2) * np.cos(np.arctan(P["RBY2"] * (a - P["RBY3"])))
            * P["LYKA"])


def _gyk(P, s):
    shyk = P["RHY1"] + P["RHY2"] * s.dfz
    eyk = P["REY1"] + P["REY2"] * s.dfz
    byk = _byk(P, s)
    return (magic_cosine(byk, P["RCY1"], eyk, s.kappa + shyk)
            / magic_cosine(byk, P["RCY1"], eyk, shyk))


#: The combined-slip stages: the switches (all zero: no combined-slip term to constrain), the
#: slip the B margin varies with, and the (name, margin) of the B, E and G constraints
_COMBINED = {
    "Fx": (("RBX1", "RBX3"), "kappa", ("Bxa > 0", _bxa),
           ("Exa <= 1", lambda P, s: 1 - (P["REX1"] + P["REX2"] * s.dfz)),
           ("Gxa > 0", longitudinal.gx_alpha)),
    "Fy": (("RBY1", "RBY3", "RBY4"), "alpha", ("Byk > 0", _byk),
           ("Eyk <= 1", lambda P, s: 1 - (P["REY1"] + P["REY2"] * s.dfz)),
           ("Gyk > 0", _gyk)),
}


# ----- constraints per stage ----------------------------------------------------------------

Merge = Callable[[Mapping[str, float]], Mapping[str, float]]


NEAR = 0.01
"""Constraint.local of a grid condition: the grid points of each load whose margin is within
NEAR x (the load's range of margins) of its minimum. The finite-difference steps of the
constrained polish (1.5e-8 in its whitened variables) move a margin by far less, so the
minimum over these points is the minimum over the grid at every step, and the Jacobian the
same as over the whole grid (exactly, up to ties that change order within the step)."""


def _make(name: str, merge: Merge, s: OperatingState, margin) -> Constraint:
    def margins(values, at: OperatingState = s) -> np.ndarray:
        return np.asarray(margin(merge(values), at) + np.zeros(at.fz.shape), dtype=float)

    def fun(values):
        return _per_load(margins(values))

    def local(values):
        m = margins(values).reshape(GRID_POINTS, -1)
        if not np.all(np.isfinite(m)):
            return fun
        low = m.min(axis=1, keepdims=True)
        near = np.flatnonzero(m <= low + NEAR * (m.max(axis=1, keepdims=True) - low))
        if near.size == m.size:
            return fun
        load = near // m.shape[1]
        at = subset_state(s, near)

        def near_fun(values1):
            v = margins(values1, at)
            out = np.full(v.shape[:-1] + (GRID_POINTS,), np.inf)
            np.minimum.at(out, (..., load), v)
            return out
        return near_fun
    return Constraint(name, fun, local, batched=True)


def stage_constraints(stage: str, base: Mapping[str, float], merge: Merge,
                      pressures: Sequence[float]) -> tuple[Constraint, ...]:
    """The validity constraints of one MF stage.

    Parameters
    ----------
    stage : str
        ``"Fx0"``, ``"Fy0"``, ``"Mz0"``, ``"Fx"``, ``"Fy"`` (others have none).
    base : mapping
        Start values of every .tir key (the limits and the RBX/RBY switches are read here).
    merge : callable
        values of the stage's parameters -> complete parameter mapping.
    pressures : sequence of float [Pa]
        The inflation pressures present in the data.

    Returns
    -------
    tuple of Constraint
        Each ``fun(values)`` returns 11 margins (one per grid load) that must be >= 0.
    """
    grid = validity_grid(base, pressures)
    fz_only = _state(base, grid, ())
    if stage == "Fx0":
        sd = _state(base, grid, ("gamma", "p"))
        se = _state(base, grid, ("kappa",))
        return (_make("Cx > 0", merge, fz_only, lambda P, s: P["PCX1"] * P["LCX"]),
                _make("Dx > 0", merge, sd, lambda P, s: longitudinal.fx0(P, s).mux),
                _make("Ex <= 1", merge, se, lambda P, s: 1 - _ex(P, s)))
    if stage == "Fy0":
        sd = _state(base, grid, ("gamma", "p"))
        se = _state(base, grid, ("alpha", "gamma", "p"))
        return (_make("Cy > 0", merge, fz_only, lambda P, s: P["PCY1"] * P["LCY"]),
                _make("Dy > 0", merge, sd, lambda P, s: lateral.fy0(P, s).muy),
                _make("Ey <= 1", merge, se, lambda P, s: 1 - _ey(P, s, lateral.fy0(P, s))))
    if stage == "Mz0":
        sb = _state(base, grid, ("gamma",))
        se = _state(base, grid, ("alpha", "gamma"))
        return (_make("Bt > 0", merge, sb, _bt),
                _make("Ct > 0", merge, fz_only, lambda P, s: P["QCZ1"]),
                _make("Et <= 1", merge, se, lambda P, s: 1 - _et(P, s)))
    if stage in _COMBINED:
        switches, slip, (b_name, b), (e_name, e), (g_name, g) = _COMBINED[stage]
        if all(base[k] == 0 for k in switches):
            return ()
        sb = _state(base, grid, (slip, "gamma_abs"))
        sg = _state(base, grid, ("kappa", "alpha", "gamma_abs"))
        return (_make(b_name, merge, sb, b), _make(e_name, merge, fz_only, e),
                _make(g_name, merge, sg, g))
    return ()


def violations(P: Mapping[str, float], pressures: Sequence[float]) -> tuple[str, ...]:
    """The validity conditions a complete parameter set ``P`` breaks within its own limits.

    Every stage's conditions (:func:`stage_constraints`) evaluated at ``P`` on the grid of
    P's limits and the ``pressures`` [Pa]: MFeval's ``coefficientCheck`` of a written .tir.
    A condition is broken when it fails by more than the fits' FEASIBLE_TOL
    (identify.fit.solve.engine.violation): a constrained stage leaves an active condition within
    round-off of its bound (a generated TTC session, seed 12: Eyk <= 1 at -3.1e-14). Returns
    one line per broken condition, "Fy0: Ey <= 1 fails at Fz = 1000 N (margin -0.12)", the
    load being the grid load of the least margin; empty when all hold.
    """
    grid = validity_grid(P, pressures)
    out = []
    for stage in CONSTRAINED_STAGES:
        for c in stage_constraints(stage, P, lambda values: P, pressures):
            margin = c.fun({})
            worst = int(np.nanargmin(margin)) if np.isfinite(margin).any() else 0
            # the fits' one feasibility test: an active condition ends within round-off
            # (-3e-14) of its bound; NaN breaks it
            if violation(margin) > FEASIBLE_TOL:
                out.append(f"{stage}: {c.name} fails at Fz = {grid.fz[worst]:.0f} N "
                           f"(margin {margin[worst]:.3g})")
    return tuple(out)
