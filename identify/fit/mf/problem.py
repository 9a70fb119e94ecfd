"""An MF stage's fitting problem: its points, free and held coefficients, model, Jacobian and
validity constraints (:func:`stage_problem`), and the same problem on a subset of its points
(:func:`subproblem`, the search's subsample). identify.fit.mf.stages fits it; the staged
jackknife (identify.fit.mf.uncertainty) and MCMC rebuild it at the final values.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import lmfit
import numpy as np
import pandas as pd

from identify.fit.bounds import start_bounds
from identify.fit.mf import stage_data as mf_data
from identify.fit.mf.constraints import stage_constraints
from identify.fit.mf.jacobian import stage_jacobian
from identify.fit.mf.result import point_columns
from identify.fit.mf.screen import screen as sensitivity_screen
from identify.fit.mf.screen import term_magnitudes
from identify.fit.mf.stage_specs import (
    EVEN_START,
    STAGES,
    StageDef,
    stage_model,
    subset_state,
)
from identify.fit.result import FitResult
from identify.fit.solve.problem import FitProblem
from identify.model.modes import FIT_MODE
from identify.model.parameters import spec
from identify.model.state import OperatingState, prepare

__all__ = ["StagePoints", "StageProblem", "candidates", "fitted_problem", "stage_problem",
           "subproblem"]


@dataclass(frozen=True)
class StageProblem:
    """A stage ready to fit.

    Attributes
    ----------
    problem : FitProblem       relation "MF", form = stage name
    rows : ndarray             row positions of the stage's points in the trailer table
    held : dict name -> reason  candidate coefficients held by the identifiability rules
    state : OperatingState     the stage's points, prepared with useMode 211
    omega : ndarray or None    the measured wheel speed [rad/s] (stage geometry only)
    wide : dict name -> (lo, hi)  bounds that replace the table's (identify.fit.bounds: the
                               arbitrary ends the stage widened); a later build ``like`` this
                               one keeps them
    """

    problem: FitProblem
    rows: np.ndarray
    held: Mapping[str, str]
    state: OperatingState
    omega: np.ndarray | None = None
    params: Mapping[str, float] | None = None
    points: StagePoints | None = dataclasses.field(default=None, repr=False, compare=False)
    wide: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)


@dataclass(frozen=True)
class StagePoints:
    """What a stage's problem takes from its rows of the trailer table, whatever the
    parameter values but the nominal load: a later build of the same stage on the same table
    reuses it (stage_problem(like=); the row selection, the table's rows, their sweeps and
    pressure groups cost 10-30 ms a build on a TTC session).

    Attributes
    ----------
    rows : ndarray           row positions in the trailer table
    pts : DataFrame          those rows
    col : dict               Fz, kappa, alpha, gamma, Vx, p of the rows (ndarray each)
    omega : ndarray or None  wheel speed [rad/s] (stage geometry only)
    measured : ndarray       the fitted quantity
    extra : dict             FitProblem.extra
    groups : ndarray         pressure group of every row [bar]
    sweeps : ndarray         sweep number of every row
    levels : ndarray         the data's pressure levels (the validity grid's)
    fnomin : float           the nominal load [N] the sweeps were numbered with
    """

    rows: np.ndarray
    pts: pd.DataFrame
    col: Mapping[str, np.ndarray]
    omega: np.ndarray | None
    measured: np.ndarray
    extra: Mapping[str, object]
    groups: np.ndarray
    sweeps: np.ndarray
    levels: np.ndarray
    fnomin: float


def _stage_points(sd: StageDef, trailer: pd.DataFrame, rows: np.ndarray,
                  fnomin: float) -> StagePoints:
    pts = trailer.iloc[rows]
    col = {c: pts[c].to_numpy(float) for c in ("Fz", "kappa", "alpha", "gamma", "Vx", "p")}
    # the validity grid at the data's pressure levels (a continuously measured pressure
    # channel has as many distinct values as samples)
    return StagePoints(
        rows, pts, col, pts["omega"].to_numpy(float) if sd.quantity in mf_data.DERIVED else None,
        mf_data.quantity_values(pts, sd.quantity),
        {"quantity": sd.quantity, **point_columns(pts)}, mf_data.pressure_groups(pts),
        mf_data.sweep_ids(pts, fnomin),
        mf_data.level_values(col["p"], mf_data.PRESSURE_RESOLUTION), fnomin)


def candidates(sd: StageDef, free) -> list[str]:
    """The coefficients of stage ``sd`` that a fit may free (the parameter table's
    ``fit_default_vary`` ones), limited by ``free`` (see :func:`stage_problem`)."""
    names = [n for n in sd.coefficients if spec(n).fit_default_vary]
    if free is None:
        return names
    if isinstance(free, Mapping):
        return list(free[sd.name]) if sd.name in free else names
    return [n for n in names if n in set(free)]


def stage_problem(stage: str, trailer: pd.DataFrame, params: Mapping[str, float], *,
                  free: Mapping[str, Sequence[str]] | Collection[str] | None = None,
                  screen: bool = True,
                  hold: Mapping[str, str] | None = None,
                  like: StageProblem | None = None,
                  sweeps: mf_data.Sweeps | None = None,
                  wide: Mapping[str, tuple[float, float]] | None = None
                  ) -> StageProblem | None:
    """Build the FitProblem of one stage at the current values ``params``.

    Parameters
    ----------
    stage : str
        Stage name (``"geometry"``, ``"Fx0"`` ... ``"My"``).
    trailer : DataFrame
        The trailer table (see identify.fit.mf.stage_data); a freely rolling run's kappa is taken
        as 0 (mf_data.rolling_kappa).
    params : mapping
        Every .tir value (start values; held values are taken from here).
    free : mapping or collection, optional
        Mapping stage -> coefficients replaces a stage's candidate list; a collection limits
        every stage's candidates to its members. The identifiability rules still apply.
    screen : bool
        Apply the identifiability rules (coverage and sensitivity); False frees every
        candidate.
    hold : mapping name -> reason, optional
        Hold exactly these candidates (no screening).
    like : StageProblem, optional
        An earlier problem of the same stage on the same ``trailer``: its points
        (:class:`StagePoints`) are reused instead of selected and read again.
    sweeps : mf_data.Sweeps, optional
        mf_data.run_sweeps of ``trailer``, when the caller has them (identify.fit.mf.stages
        takes them once for every stage rather than twice per stage).

    Returns
    -------
    StageProblem or None
        None when the table holds no point for the stage.
    """
    sd = STAGES[stage]
    wide = dict(like.wide if wide is None and like is not None else wide or {})
    fnomin = float(params["FNOMIN"])
    at = like.points if like is not None else None
    if at is None or at.fnomin != fnomin:
        # the table as identify.fit.mf.stages.fit_mf fits it, whoever builds the problem
        # again (stage_mcmc, mf_uncertainty.propagate, identify.discover)
        if sweeps is None:
            sweeps = mf_data.run_sweeps(trailer)
        trailer = mf_data.rolling_kappa(trailer, sweeps)  # the same run_sweeps after it
        rows = (mf_data.select(trailer, sd.selection, sd.quantity, sweeps) if like is None
                else like.rows)
        if rows.size == 0:
            return None
        at = _stage_points(sd, trailer, rows, fnomin)
    rows, pts, col, omega, measured = at.rows, at.pts, at.col, at.omega, at.measured
    s = prepare(params, col["Fz"], col["kappa"], col["alpha"], col["gamma"], col["Vx"],
                p=col["p"], mode=FIT_MODE)
    model = stage_model(stage, params, s, omega)
    jacobian = stage_jacobian(stage, params, s, omega)
    held: dict[str, str] = {}
    names = candidates(sd, free)
    if hold is not None:
        held = {n: why for n, why in hold.items() if n in names}
    elif screen:
        held = mf_data.coverage_missing(pts, sd.selection, fnomin, names)

    extra, groups, sweeps = at.extra, at.groups, at.sweeps

    def build(vary: Collection[str], constraints=()) -> FitProblem:
        P = lmfit.Parameters()
        for n in names:
            v = float(params[n])
            if n in vary:  # free: start inside the table's bounds, an even term off 0
                v = EVEN_START.get(n, v) if v == 0 else v
                lo, hi = wide[n] if n in wide else start_bounds(n, v)
                P.add(n, value=min(max(v, lo), hi), min=lo, max=hi)
            else:  # held: exactly the carried-forward value
                P.add(n, value=v, vary=False)
        return FitProblem("MF", stage, P, model, measured, groups, objective="wls",
                          sigma=None, constraints=tuple(constraints), sweeps=sweeps, unit=sd.unit,
                          extra=extra, noise="sweep-residual", jacobian=jacobian,
                          covariance="sweeps")

    screened = None
    if screen and hold is None:
        screened = build([n for n in names if n not in held])
        more, _ = sensitivity_screen(screened,
                                     magnitudes=term_magnitudes(screened.free, s))
        held.update(more)
        if more:
            screened = None
    vary = [n for n in names if n not in held]

    def merge(values):
        return {**params, **values}

    cons = stage_constraints(stage, params, merge, at.levels)
    # the screen's problem when it held nothing more (the same parameters: lmfit's are slow to
    # build, ~0.06 ms each), with the constraints
    problem = (build(vary, cons) if screened is None
               else dataclasses.replace(screened, constraints=tuple(cons)))
    return StageProblem(problem, rows, held, s, omega, dict(params), at, wide)


def fitted_problem(trailer: pd.DataFrame, params: Mapping[str, float], result: FitResult
                   ) -> StageProblem | None:
    """The problem of the MF stage ``result`` fitted, built again at the staged fit's values
    ``params``: its free coefficients free, every other coefficient of the stage held ("held
    in the fit"), no screening; None when the table holds no point for it. For the work done
    after the fit on the stage's optimum (identify.fit.mf.uncertainty.propagate,
    identify.fit.mf.profile, identify.fit.mf.stages.stage_mcmc); the caller checks that its
    ``problem.free`` is ``result.free``."""
    hold = {n: "held in the fit" for n in result.parameters if n not in result.free}
    return stage_problem(result.form, trailer, params, free={result.form: list(result.parameters)},
                         hold=hold, wide=dict(result.bounds))


def subproblem(sp: StageProblem, index: np.ndarray) -> FitProblem:
    """``sp``'s problem on its points ``index`` (the search's subsample): the same parameters,
    free set and constraints."""
    p = sp.problem
    s = subset_state(sp.state, index)
    omega = None if sp.omega is None else sp.omega[index]
    return dataclasses.replace(
        p, model=stage_model(p.form, sp.params, s, omega), measured=p.measured[index],
        pressure_bar=p.pressure_bar[index],
        sweeps=None if p.sweeps is None else p.sweeps[index], extra={},
        jacobian=stage_jacobian(p.form, sp.params, s, omega, exact=p.jacobian is not None))
