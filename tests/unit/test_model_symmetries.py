"""identify.model.symmetries: each listed sign change leaves every output unchanged.

The golden test set (tests/data/reference/golden) has every coefficient non-zero, so a mirror
that is not exact changes some output. The operating points cover combined slip of both
signs, camber of both signs, three loads and three pressures.
"""
from __future__ import annotations

import numpy as np
import pytest

from identify.io.tir import read_tir
from identify.model.evaluate import OUTPUT_COLUMNS, evaluate
from identify.model.symmetries import MIRRORS, aligned, nearest_image, sign_patterns
from tests.reference_data import GOLDEN_DIR

FZ, KAPPA, ALPHA, GAMMA, P = (a.ravel() for a in np.meshgrid(
    [2500.0, 5000.0, 7500.0], [-0.12, -0.02, 0.0, 0.05], [-0.15, -0.03, 0.0, 0.08],
    [-0.05, 0.0, 0.06], [2.0e5, 2.5e5, 3.0e5], indexing="ij"))


def _outputs(values: dict, mode: int) -> np.ndarray:
    out = evaluate(values, FZ, KAPPA, ALPHA, GAMMA, 16.7, p=P, mode=mode)
    return np.column_stack([np.asarray(out[c], dtype=float) for c in OUTPUT_COLUMNS])


@pytest.fixture(scope="module", params=["testA_61", "testA_62"])
def golden(request):
    values = read_tir(GOLDEN_DIR / f"{request.param}.tir").params()
    return values, {mode: _outputs(values, mode) for mode in (111, 211)}


@pytest.mark.parametrize("mirror", MIRRORS, ids=lambda m: "-".join(m.names))
def test_each_mirror_changes_no_output(golden, mirror):
    values, base = golden
    assert all(values[n] != 0 for n in mirror.names)  # else the check would prove nothing
    flipped = {**values, **{n: -values[n] for n in mirror.names}}
    for mode, expected in base.items():
        # bit for bit: a negated IEEE number is exact, and cos(atan), squares and products of
        # two odd functions give back the same bits
        np.testing.assert_array_equal(_outputs(flipped, mode), expected, err_msg=f"mode {mode}")


@pytest.mark.parametrize("mirror", [m for m in MIRRORS if len(m.names) > 1],
                         ids=lambda m: "-".join(m.names))
def test_half_a_mirror_changes_the_outputs(golden, mirror):
    """The control: flipping only the first coefficient of a group does change an output, so
    the test above could fail."""
    values, base = golden
    half = {**values, mirror.names[0]: -values[mirror.names[0]]}
    with np.errstate(invalid="ignore"):  # half a mirror can leave the domain: NaN at points
        assert np.nanmax(np.abs(_outputs(half, 211) - base[211])) > 1e-6


def test_sign_patterns_group_and_held_zero():
    names = ("RVY1", "RVY2", "RVY3", "RVY4", "RVY5", "RVY6")
    s = sign_patterns(names)
    # RVY4 alone, (RVY5, RVY1..3), (RVY6, RVY1..3): 8 products, the identity first
    assert s.shape == (8, 6) and np.all(s[0] == 1)
    assert {tuple(r) for r in s} >= {(1, 1, 1, 1, -1, -1), (-1, -1, -1, 1, 1, -1)}
    # RVY5 held at a non-zero value: only RVY4 and the RVY6 group are left
    assert sign_patterns(names[:4] + ("RVY6",), held={"RVY5": 1.9}).shape == (4, 5)
    # QBZ10 held at 0 is its own image: QBZ9 alone may change sign
    assert sign_patterns(("QBZ9",), held={"QBZ10": 0.0}).tolist() == [[1.0], [-1.0]]
    assert sign_patterns(("QBZ9",), held={"QBZ10": 0.2}).tolist() == [[1.0]]


def test_nearest_image_and_aligned_truth():
    s = sign_patterns(("QBZ9", "QBZ10"))
    assert nearest_image(np.array([12.3, -0.38]), np.array([-15.0, 0.25]), s).tolist() \
        == [-12.3, 0.38]
    assert nearest_image(np.array([12.3, -0.38]), np.array([15.0, -0.25]), s).tolist() \
        == [12.3, -0.38]
    truth = {"RVY1": 0.5, "RVY2": 0.8, "RVY3": 50.0, "RVY4": 40.0, "RVY5": 1.9, "RVY6": -10.0,
             "PDY1": 1.0}
    fit = {"RVY1": -0.5008, "RVY2": -0.80, "RVY3": -50.0, "RVY4": -40.04, "RVY5": 1.907,
           "RVY6": 9.95}
    image = aligned(truth, fit, list(fit))
    assert image == {"RVY1": -0.5, "RVY2": -0.8, "RVY3": -50.0, "RVY4": -40.0, "RVY5": 1.9,
                     "RVY6": 10.0, "PDY1": 1.0}
    # only RVY6 compared: RVY1..3 change sign with it all the same (the same tyre)
    assert aligned(truth, {"RVY6": 9.95}, ["RVY6"])["RVY1"] == -0.5
