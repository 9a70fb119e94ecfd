"""What a discovery run found: frozen dataclasses with ``to_dict()`` (discovery.json).

``discovery.json`` (schema ``mfid.discovery/1``) is a stable interface::

    base            {kind, name, tir, problems: [problem summaries]}
    steps           [{step, candidates: [candidate table rows], tried: [...], accepted}]
    accepted        [{name, coefficients {name: value}, error_before_pct, error_after_pct,
                      heldout_before_pct, heldout_after_pct, p_value, ...}]
    noise_floor_pct, excess_explained, conclusion
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from identify.core.jsonsafe import json_float as _num
from identify.core.jsonsafe import json_floats as _nums
from identify.core.serial import Serial, meta
from identify.discover.noise import NoiseModel

__all__ = ["CandidateRow", "Trial", "Step", "Accepted", "ProblemSummary", "Discovery",
           "SCHEMA"]

SCHEMA = "mfid.discovery/1"


@dataclass(frozen=True)
class CandidateRow(Serial):
    """One row of a step's candidate table.

    Attributes
    ----------
    name, problem : str
    coefficients : tuple of str
    equation, description : str
    testable : bool
    rel_norm : float              ||M G|| / ||G|| [-]
    statistic : float             one-step F form of the LM test, or robust Wald/q
    dof : int
    p_value, p_holm : float       raw and Holm-adjusted
    predicted_error_pct : float   thesis error predicted after adding it (one step) [%]
    predicted_explained : float   predicted fraction of the excess error explained [-]
    cosines : Mapping[str, float] |cos| with the other candidates of the problem
    ambiguity_group : tuple of str other candidates it cannot be told apart from
    passes : bool                 Holm and predicted-drop requirements met
    """

    name: str
    problem: str
    coefficients: tuple[str, ...]
    equation: str
    description: str
    testable: bool
    rel_norm: float
    statistic: float
    dof: int
    p_value: float
    p_holm: float
    predicted_error_pct: float
    predicted_explained: float
    cosines: Mapping[str, float]
    ambiguity_group: tuple[str, ...]
    passes: bool



@dataclass(frozen=True)
class Trial(Serial):
    """One refit-and-confirm attempt.

    Attributes
    ----------
    name, problem : str
    coefficients, stderr : Mapping[str, float]   refitted values and standard errors
    test : str                      ``"F"`` or ``"cluster-robust Wald"``
    statistic, p_value, p_adjusted : float
    error_before_pct, error_after_pct : float     training thesis error [%]
    heldout_before_pct, heldout_after_pct : float held-out thesis error [%]
    heldout_scheme : str            ``"leave one pressure out"``, ``"sweep folds"`` ...
    accepted : bool
    reason : str
    """

    name: str
    problem: str
    coefficients: Mapping[str, float]
    stderr: Mapping[str, float]
    test: str
    statistic: float
    p_value: float
    p_adjusted: float
    error_before_pct: float
    error_after_pct: float
    heldout_before_pct: float
    heldout_after_pct: float
    heldout_scheme: str
    accepted: bool
    reason: str

    serial_order = ("name", "problem", "test", "heldout_scheme", "accepted", "reason",
                    "statistic", "p_value", "p_adjusted", "error_before_pct",
                    "error_after_pct", "heldout_before_pct", "heldout_after_pct")


@dataclass(frozen=True)
class Step(Serial):
    """One forward step: the candidate table, the attempts, what was accepted."""

    index: int = field(metadata=meta(key="step"))
    candidates: tuple[CandidateRow, ...]
    tried: tuple[Trial, ...]
    accepted: str | None



@dataclass(frozen=True)
class Accepted(Serial):
    """An accepted effect (the discovery.json ``accepted`` entries).

    ``p_value`` is the F test's (or cluster-robust Wald test's) p-value after the refit, Holm
    adjusted; errors are thesis totals [%] before/after; ``ambiguous_with`` names the
    candidates it cannot be told apart from (then it is not a confident name); the
    coefficients and standard errors are the final ones (what the .tir holds), the errors those
    of the step that accepted it; ``heldout_scheme`` names the folds of the held-out check."""

    name: str
    problem: str
    description: str
    coefficients: Mapping[str, float]
    stderr: Mapping[str, float]
    error_before_pct: float
    error_after_pct: float
    heldout_before_pct: float
    heldout_after_pct: float
    p_value: float
    ambiguous_with: tuple[str, ...] = ()
    noise_floor_pct: float = float("nan")
    excess_explained: float = float("nan")
    note: str = ""
    heldout_scheme: str = ""

    serial_order = ("name", "problem", "description", "coefficients", "stderr",
                    "ambiguous_with", "note", "heldout_scheme")


@dataclass(frozen=True)
class ProblemSummary(Serial):
    """One problem's base fit, diagnosis and final state.

    Attributes
    ----------
    name, relation, form, unit : str
    n_points : int
    free : tuple of str             base model's fitted parameters
    candidates : tuple of str       library candidates tested on it
    base_error_pct, final_error_pct : float    total error [%]: the thesis metric; for moments
                                    relative to each group's range
                                    (:func:`identify.discover.prepared_problem.by_range`)
    base_error_by_pressure_pct : Mapping[float, float]
    converged, stationary : bool    base fit status
    message : str
    noise, base_noise : NoiseModel  error model of the final and of the base model
    noise_floor_pct : float         error of the noise alone [%] (the same metric)
    floor_source : str
    cells, final_cells : tuple of dict   error per condition cell (pressure x load level x
                                    camber) of the base and the final model [%] (the same
                                    metric) and its RMS ``rms`` [unit]
    fit_seconds, score_seconds : float   one base fit; scoring all its candidates
    parameters, stderr : Mapping    final values of every parameter; errors of the free ones
    final_free : tuple of str
    arrays : Mapping[str, ndarray]  per-point data for the report (not in to_dict)
    fit : FitResult                 the final fit (fit.json; not in to_dict)
    heldout_scheme : str            folds of the held-out check, chosen from the design
    reads : Mapping[str, str]       parameters taken from another problem -> that problem
    upstream : tuple of str         problems whose coefficients it uses (its read parameters,
                                    and the models it is rebuilt from: Fy for Mx and Mz)
    """

    name: str
    relation: str
    form: str
    unit: str
    n_points: int
    free: tuple[str, ...]
    candidates: tuple[str, ...]
    base_error_pct: float
    final_error_pct: float
    base_error_by_pressure_pct: Mapping[float, float] = field(metadata=meta(key_format="g"))
    converged: bool
    stationary: bool
    message: str
    noise: NoiseModel
    base_noise: NoiseModel
    noise_floor_pct: float
    floor_source: str
    cells: tuple[dict, ...]
    final_cells: tuple[dict, ...]
    fit_seconds: float
    score_seconds: float
    parameters: Mapping[str, float]
    stderr: Mapping[str, float]
    final_free: tuple[str, ...]
    arrays: Mapping[str, np.ndarray] = field(default_factory=dict, repr=False, compare=False,
                                             metadata=meta(skip=True))
    fit: Any = field(default=None, repr=False, compare=False, metadata=meta(skip=True))
    heldout_scheme: str = ""
    reads: Mapping[str, str] = field(default_factory=dict)
    upstream: tuple[str, ...] = ()

    @property
    def excess_explained(self) -> float:
        return excess_explained(self.base_error_pct, self.final_error_pct, self.noise_floor_pct)

    #: discovery.json's key order: the fields to ``floor_source``, the derived
    #: ``excess_explained``, then the other fields (the arrays and the fit are not written)
    serial_derived = {"excess_explained": lambda self: self.excess_explained}
    serial_order = ("name", "relation", "form", "unit", "n_points", "free", "candidates",
                    "base_error_pct", "final_error_pct", "base_error_by_pressure_pct",
                    "converged", "stationary", "message", "noise", "base_noise",
                    "noise_floor_pct", "floor_source", "excess_explained")


def excess_explained(before: float, after: float, floor: float) -> float:
    """(eps0^2 - eps1^2) / (eps0^2 - eps_floor^2); NaN without excess error [-]."""
    den = before ** 2 - floor ** 2
    return (before ** 2 - after ** 2) / den if den > 0 else float("nan")


@dataclass(frozen=True)
class Discovery:
    """The whole run.

    Attributes
    ----------
    base : Mapping            {kind, name, tir}
    problems : tuple of ProblemSummary
    steps : tuple of Step
    accepted : tuple of Accepted
    noise_floor_pct, excess_explained : float   of the first accepted effect's problem (or of
                                                the problem with the largest error when none)
    conclusion : str
    settings : Mapping
    seconds : float
    state : Mapping[str, float]   the one model state: every key some problem fits or tests,
                                  at its final value (what the .tir gets)
    sources : Mapping[str, str]   key -> the problem it comes from
    notes : tuple of str          problems not analysed, and why
    """

    base: Mapping[str, Any]
    problems: tuple[ProblemSummary, ...]
    steps: tuple[Step, ...]
    accepted: tuple[Accepted, ...]
    noise_floor_pct: float
    excess_explained: float
    conclusion: str
    settings: Mapping[str, Any]
    seconds: float
    state: Mapping[str, float] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    @property
    def named(self) -> str | None:
        """The first confidently named effect (None when nothing or an ambiguity group)."""
        if not self.accepted or self.accepted[0].ambiguous_with:
            return None
        return self.accepted[0].name

    def to_dict(self) -> dict[str, Any]:
        base = dict(self.base)
        base["problems"] = [p.to_dict() for p in self.problems]
        return {"schema": SCHEMA, "base": base, "steps": [s.to_dict() for s in self.steps],
                "accepted": [a.to_dict() for a in self.accepted],
                "noise_floor_pct": _num(self.noise_floor_pct),
                "excess_explained": _num(self.excess_explained),
                "conclusion": self.conclusion, "settings": dict(self.settings),
                "seconds": self.seconds,
                "model": {"parameters": _nums(self.state), "sources": dict(self.sources)},
                "notes": list(self.notes)}
