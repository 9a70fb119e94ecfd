"""The image of an MF stage's optimum that keeps the signs of the values it started from.

Sign changes such as (QBZ9, QBZ10) -> (-QBZ9, -QBZ10) or (RVY1..3, RVY6) -> -(RVY1..3, RVY6)
leave every output unchanged (identify.model.symmetries), so the data cannot choose between
the images and the search reports whichever it reached. An engineer who compares the written
.tir with the one the fit started from (a previous fit, a supplier's file) should not find
RVY6 = +10 where the start had -10 for the same tyre: the stage reports the image nearest its
start values, among the images inside the bounds.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping

import numpy as np

from identify.fit.result import FitResult, Rival
from identify.model.symmetries import nearest_image, sign_patterns

__all__ = ["canonical_signs", "flipped"]


def canonical_signs(result: FitResult, start: Mapping[str, float]) -> FitResult:
    """``result`` as the image of its optimum nearest ``start`` (distance relative to
    max(|start|, 1e-3)); correlations, rivals and profile ends change sign with it.

    Parameters
    ----------
    result : FitResult
        An MF stage's fit.
    start : Mapping[str, float]
        The values the stage started from, held coefficients included (a mirror with a held
        coefficient applies only when that coefficient is 0).
    """
    free = tuple(result.free)
    signs = sign_patterns(free, start)
    if len(signs) <= 1:
        return result
    x = np.array([float(result.parameters[n]) for n in free])
    lo, hi = np.array([result.bounds.get(n, (-np.inf, np.inf)) for n in free], dtype=float).T
    inside = signs[np.all((signs * x >= lo) & (signs * x <= hi), axis=1)]
    image = nearest_image(x, np.array([float(start[n]) for n in free]), inside)
    return flipped(result, {n for n, a, b in zip(free, image, x) if a != b})


def flipped(result: FitResult, names: Collection[str]) -> FitResult:
    """``result`` with the coefficients ``names`` of the other sign (an image of its optimum:
    the caller knows the change leaves the predictions alone), and with them the signs of
    their correlations with the others, their rivals' values and their profile ends;
    ``result`` itself when ``names`` is empty."""
    flip = set(names)
    if not flip:
        return result

    def signed(name: str, value: float) -> float:
        return -value if name in flip else value

    corr = {k: (-c if len(flip & set(k.split("|"))) == 1 else c)
            for k, c in result.correlations.items()}
    rivals = tuple(Rival({n: signed(n, v) for n, v in r.values.items()}, r.dchi2)
                   for r in result.rivals)
    profile = {n: ((-e[1], -e[0]) if n in flip else e) for n, e in result.profile.items()}
    return dataclasses.replace(
        result, parameters={n: signed(n, v) for n, v in result.parameters.items()},
        correlations=corr, rivals=rivals, profile=profile)
