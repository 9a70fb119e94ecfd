"""A drift along the session as a candidate effect: absorbed, or reported, never a pressure law.

Trailer sessions run for an hour or more; the tread warms, wears and the rig drifts. The pressure
blocks of a session follow each other in time, so a slow trend in the forces can pass for a
pressure effect. The library's ``DRIFT`` candidate (``nuisance = true``) scales a problem's
output by a linear trend along the session,

    F = F_MF (1 + MFID_DRIFT tau),     tau = -1 at the session's first sample, +1 at its last,

``tau`` from ``extra["session_pos"]`` (the sample's position in the session, row order of the
trailer table: runs in manifest order, time within a run). It competes with the pressure
candidates in every step: a trend that is really a drift is named as one (or as an ambiguity
group with the pressure law it mimics), never as a confident pressure law. A drift is a property
of the measurement, not of the tyre: its coefficient is local to its problem and is never
written to the .tir.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from identify.fit.solve.problem import FitProblem

__all__ = ["DRIFT_KEY", "with_drift", "drifting", "session_positions"]

DRIFT_KEY = "MFID_DRIFT"
"""The drift coefficient: relative change of the output from the session's middle to its end."""


def session_positions(n: int) -> np.ndarray:
    """tau of ``n`` samples in session order: -1 .. +1."""
    return np.linspace(-1.0, 1.0, n) if n > 1 else np.zeros(n)


def drifting(model, jac, tau: np.ndarray):
    """(model, Jacobian) scaled by (1 + MFID_DRIFT tau); the Jacobian None when ``jac`` is."""

    def drift_model(v):
        return model(v) * (1.0 + v[DRIFT_KEY] * tau)

    def drift_jac(v, names):
        scale = (1.0 + v[DRIFT_KEY] * tau)[:, None]
        own = tuple(n for n in names if n != DRIFT_KEY)
        cols = dict(zip(own, (jac(v, own).reshape(tau.size, len(own)) * scale).T)) \
            if own else {}
        if DRIFT_KEY in names:
            cols[DRIFT_KEY] = np.asarray(model(v), dtype=float) * tau
        return np.stack([cols[n] for n in names], axis=1)

    return drift_model, (drift_jac if jac is not None else None)


def with_drift(problem: FitProblem) -> FitProblem:
    """``problem`` with the drift coefficient (fixed at its neutral 0) in its model and, if it
    has one, its exact Jacobian. Requires ``extra["session_pos"]``."""
    tau = np.asarray(problem.extra["session_pos"], dtype=float)
    model, jac = drifting(problem.model, problem.jacobian, tau)
    P = problem.parameters.copy()
    P.add(DRIFT_KEY, value=0.0, vary=False)
    return dataclasses.replace(problem, parameters=P, model=model, jacobian=jac)
