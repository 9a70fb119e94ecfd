"""The end of a discovery run: accepted effects at their final values, floors, the headline."""
from __future__ import annotations

import dataclasses

import numpy as np

from identify.discover.library import Candidate
from identify.discover.result import Accepted, ProblemSummary, excess_explained

__all__ = ["sign_note", "taken_over_note", "final_accepted", "headline", "TAKEN_OVER_SE"]

TAKEN_OVER_SE = 2.0
"""An accepted effect whose every final coefficient lies within this many standard errors of
its neutral value is reported as taken over by the effects added after it."""


def sign_note(cand: Candidate, values: dict) -> str:
    if not cand.expected_sign:
        return ""
    k = next(iter(cand.coefficients))
    dev = values[k] - cand.coefficients[k]
    if (cand.expected_sign == "+" and dev < 0) or (cand.expected_sign == "-" and dev > 0):
        return f"sign opposite to the physically expected one ({cand.expected_sign})"
    return ""


def taken_over_note(cand: Candidate, values: dict, stderr: dict) -> str:
    """A note when every final coefficient of ``cand`` is within :data:`TAKEN_OVER_SE` standard
    errors of its neutral value (an effect named early, then explained by later additions:
    the drift of a session whose pressure blocks follow each other in time), else ''."""
    devs = [abs(values[k] - v) / stderr[k] for k, v in cand.coefficients.items()
            if k in values and np.isfinite(stderr.get(k, np.nan)) and stderr[k] > 0]
    if not devs or max(devs) >= TAKEN_OVER_SE:
        return ""
    return ("the effects added after it took it over: its final value is within "
            f"{TAKEN_OVER_SE:g} standard errors of neutral")


def final_accepted(accepted: list[Accepted], probs: tuple[ProblemSummary, ...],
                   candidates: dict[str, Candidate]) -> list[Accepted]:
    """Each accepted effect with its problem's final noise floor and its coefficients (and
    standard errors) at their final values: later steps and updates from upstream problems
    refit them, and what is reported must be what the .tir holds."""
    by = {p.name: p for p in probs}
    out = []
    for a in accepted:
        s = by[a.problem]
        f = s.noise_floor_pct
        coefs = {k: float(s.parameters.get(k, v)) for k, v in a.coefficients.items()}
        se = {k: float(s.stderr.get(k, a.stderr.get(k, float("nan")))) for k in coefs}
        cand = candidates.get(a.name)
        note = a.note
        if cand is not None:
            note = "; ".join(n for n in (sign_note(cand, coefs),
                                         taken_over_note(cand, coefs, se)) if n)
        out.append(dataclasses.replace(
            a, coefficients=coefs, stderr=se, noise_floor_pct=f,
            excess_explained=excess_explained(a.error_before_pct, a.error_after_pct, f),
            note=note))
    return out


def headline(accepted, probs) -> tuple[float, float]:
    if accepted:
        return accepted[0].noise_floor_pct, accepted[0].excess_explained
    if not probs:
        return float("nan"), float("nan")
    worst = max(probs, key=lambda p: p.final_error_pct ** 2 - p.noise_floor_pct ** 2
                if np.isfinite(p.noise_floor_pct) else -np.inf)
    return worst.noise_floor_pct, float("nan")
