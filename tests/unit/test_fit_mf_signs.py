"""identify.fit.mf.minima.sign_images: an MF stage reports the mirror image of its optimum nearest
its start."""
from __future__ import annotations

import math

import numpy as np

from identify.fit.mf.minima.sign_images import canonical_signs
from identify.fit.result import FitResult, Rival

# the golden test set's combined-slip side force (tests/data/tir/testA_61.tir)
START = {"RVY1": 0.5, "RVY2": 0.8, "RVY3": 50.0, "RVY4": 40.0, "RVY5": 1.9, "RVY6": -10.0,
         "RBY2": 8.0}
# what a TTC session of it gave (seed 3): the same tyre, in another image
FITTED = {"RVY1": -0.5008, "RVY2": -0.8009, "RVY3": -50.0016, "RVY4": -40.0041,
          "RVY5": 1.9068, "RVY6": 9.9516, "RBY2": 9.3}


def _result(values, bounds=None, **extra) -> FitResult:
    free = tuple(values)
    return FitResult(
        relation="MF", form="Fy", objective="wls", parameters=dict(values), free=free,
        stderr={n: 0.01 * abs(v) for n, v in values.items()},
        bounds=bounds or {n: (-math.inf, math.inf) for n in free}, at_bound=(),
        active_constraints=(), error_total_pct=1.0, error_by_pressure_pct={}, wls=1.0,
        n_points=100, converged=True, message="", n_starts=4, starts_at_best=4,
        correlations={"RVY1|RVY2": 0.9, "RVY1|RVY5": -0.3, "RVY4|RVY5": 0.2,
                      "RVY5|RBY2": 0.1},
        predicted=np.zeros(1), measured=np.zeros(1), pressure_bar=np.zeros(1), **extra)


def test_the_image_nearest_the_start_is_reported():
    r = _result(FITTED, rivals=(Rival({"RVY4": 39.0, "RBY2": 7.0}, 1.2),),
                profile={"RVY6": (9.7, 10.2), "RVY5": (1.88, 1.93)})
    out = canonical_signs(r, START)
    # RVY4 alone, and RVY1..3 with RVY6, change sign; RVY5 and RBY2 keep theirs
    assert out.parameters == {"RVY1": 0.5008, "RVY2": 0.8009, "RVY3": 50.0016,
                              "RVY4": 40.0041, "RVY5": 1.9068, "RVY6": -9.9516, "RBY2": 9.3}
    # a correlation changes sign when one of its two coefficients does
    assert out.correlations == {"RVY1|RVY2": 0.9, "RVY1|RVY5": 0.3, "RVY4|RVY5": -0.2,
                                "RVY5|RBY2": 0.1}
    assert out.rivals == (Rival({"RVY4": -39.0, "RBY2": 7.0}, 1.2),)
    assert out.profile == {"RVY6": (-10.2, -9.7), "RVY5": (1.88, 1.93)}
    assert out.stderr == r.stderr
    assert canonical_signs(out, START) is out  # already nearest: unchanged


def test_a_held_coefficient_or_a_bound_keeps_the_sign():
    # RVY5 held at 1.9: only RVY6 can carry RVY1..3's sign change, and RVY4 its own
    fitted = {n: v for n, v in FITTED.items() if n != "RVY5"}
    out = canonical_signs(_result(fitted), START)
    assert out.parameters["RVY6"] == -9.9516 and out.parameters["RVY1"] == 0.5008
    # ... unless RVY6 is held too (at a value other than 0)
    fitted = {n: v for n, v in fitted.items() if n != "RVY6"}
    out = canonical_signs(_result(fitted), START)
    assert out.parameters["RVY1"] == -0.5008 and out.parameters["RVY4"] == 40.0041
    # RBY2 alone is a mirror, but its bounds [0, 100] keep it positive
    r = _result({"RBY2": 9.3}, bounds={"RBY2": (0.0, 100.0)})
    assert canonical_signs(r, {"RBY2": -8.0}) is r
