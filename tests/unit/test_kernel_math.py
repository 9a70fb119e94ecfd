"""The kernel's vectorisable elementary functions against libm (numpy), over wide ranges.

Tolerance: a few units in the last place (the series are truncated below 1e-17 relative; the
rest is the round-off of ~15 multiply-adds). pow = exp(y log x) loses |y log x| ulp, as any
such pow does; the kernel calls it with |y log x| < 10.
"""
from __future__ import annotations

import numba
import numpy as np
import pytest

from identify.model.kernel import vector_math as km


def _loop(fn):
    @numba.njit(error_model="numpy")
    def loop(x, out):
        for i in range(x.size):
            out[i] = fn(x[i])
    return loop


def _apply(fn, x):
    out = np.empty_like(x)
    _loop(fn)(x, out)
    return out


def _ulp(got, ref):
    same = (got == ref) | (np.isnan(got) & np.isnan(ref))
    with np.errstate(invalid="ignore"):
        return np.where(same, 0.0, np.abs(got - ref) / np.spacing(np.abs(ref)))


RNG = np.random.default_rng(3)
SPECIAL = np.array([0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 1e-300, -1e-300, 1e300])


@pytest.mark.parametrize("name, ref, x, max_ulp", [
    ("atan", np.arctan, np.concatenate([RNG.uniform(-3, 3, 200_000),
                                         RNG.standard_cauchy(200_000) * 100, SPECIAL]), 2),
    ("sin", np.sin, np.concatenate([RNG.uniform(-10, 10, 200_000),
                                     RNG.uniform(-1e6, 1e6, 200_000), SPECIAL[:7]]), 2),
    ("cos", np.cos, np.concatenate([RNG.uniform(-10, 10, 200_000),
                                     RNG.uniform(-1e6, 1e6, 200_000), SPECIAL[:7]]), 2),
    ("tan", np.tan, np.concatenate([RNG.uniform(-1.56, 1.56, 200_000),
                                     RNG.uniform(-1e4, 1e4, 200_000), SPECIAL[:7]]), 4),
    ("exp", np.exp, np.concatenate([RNG.uniform(-745, 709, 200_000), RNG.uniform(-2, 2, 200_000),
                                     [0.0, -800.0, 800.0, np.nan, np.inf, -np.inf]]), 1),
    ("log", np.log, np.concatenate([np.exp(RNG.uniform(-700, 700, 200_000)),
                                     RNG.uniform(0, 3, 200_000),
                                     [0.0, 1.0, np.nan, np.inf, -1.0, 2.3e-308]]), 2),
])
def test_elementary_function_matches_libm(name, ref, x, max_ulp):
    with np.errstate(all="ignore"):
        expected = ref(x)
    got = _apply(getattr(km, name), x)
    assert np.array_equal(np.isnan(got), np.isnan(expected)), name
    assert np.array_equal(got[np.isinf(expected)], expected[np.isinf(expected)]), name
    assert np.max(_ulp(got, expected)) <= max_ulp, name


def test_sin_cos_tan_keep_their_identities_near_multiples_of_half_pi():
    # the reduction's three-part pi/2: results near the zeros stay accurate in absolute terms
    k = np.arange(-2000, 2000, dtype=float)
    x = k * (np.pi / 2)
    assert np.max(np.abs(_apply(km.sin, x) - np.sin(x))) < 1e-15
    assert np.max(np.abs(_apply(km.cos, x) - np.cos(x))) < 1e-15


@pytest.mark.parametrize("y", [0.0, 1.0 / 3.0, 0.85, 2.0, -1.5])
def test_pow_matches_numpy_power(y):
    x = np.concatenate([RNG.uniform(0, 5, 100_000), [0.0, 1.0, np.inf, np.nan]])

    @numba.njit(error_model="numpy")
    def loop(x, out):
        for i in range(x.size):
            out[i] = km.pow(x[i], y)
    got = np.empty_like(x)
    loop(x, got)
    with np.errstate(all="ignore"):
        expected = x ** y
    assert np.array_equal(np.isnan(got), np.isnan(expected))
    fin = np.isfinite(expected)
    assert np.array_equal(got[~fin & ~np.isnan(expected)], expected[~fin & ~np.isnan(expected)])
    rel = np.abs(got[fin] - expected[fin]) / np.maximum(np.abs(expected[fin]), 1e-300)
    assert np.max(rel) < 1e-14


def test_pow_of_a_negative_base_is_nan():
    assert np.isnan(km.pow(-1.0, 0.85))
