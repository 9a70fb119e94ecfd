"""Unit conversion to SI (identify.core.units)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from identify.core.errors import InputError
from identify.core.units import SI_UNITS, UNITS, normalize_unit, same_unit, to_si, unit_problem


@pytest.mark.parametrize("value,unit,expected", [
    (180.0, "deg", math.pi), (90.0, "degree", math.pi / 2), (1.0, "rad", 1.0),
    (250.0, "kPa", 250000.0), (2.5, "bar", 250000.0), (1.0, "psi", 6894.757293168361),
    (250000.0, "Pa", 250000.0), (0.25, "MPa", 250000.0),
    (36.0, "km/h", 10.0), (1.0, "mph", 0.44704), (16.7, "m/s", 16.7),
    (5.0, "kN", 5000.0), (1.0, "lbf", 4.4482216152605), (1.0, "kgf", 9.80665),
    (1.0, "N*m", 1.0), (1.0, "Nm", 1.0), (1.0, "N m", 1.0), (1.0, "N.m", 1.0),
    (2.0, "kNm", 2000.0), (1.0, "lbf*ft", 4.4482216152605 * 0.3048),
    (300.0, "mm", 0.3), (30.0, "cm", 0.3), (1.0, "in", 0.0254), (1.0, "m", 1.0),
    (250.0, "ms", 0.25), (2.0, "s", 2.0),
    (60.0, "rpm", 2 * math.pi), (60.0, "1/min", 2 * math.pi), (180.0, "deg/s", math.pi),
    (3.0, "rad/s", 3.0), (5.0, "%", 0.05), (0.05, "-", 0.05),
    (145.2, "N/mm", 145200.0), (20.0, "degC", 293.15), (42.0, "Hz", 42.0),
    (1.0, "Nm/deg", 180.0 / math.pi),
])
def test_to_si(value, unit, expected):
    assert to_si(value, unit) == pytest.approx(expected, rel=1e-14)


def test_arrays_are_copied_not_changed():
    values = np.array([1.0, 2.0])
    out = to_si(values, "kN")
    assert out.tolist() == [1000.0, 2000.0]
    assert values.tolist() == [1.0, 2.0]
    assert to_si(values, None) is not values


def test_normalize_and_same_unit():
    assert normalize_unit(" [N m] ") == "n*m"
    assert normalize_unit("KM/H") == "km/h"
    assert same_unit("N*m", "Nm") and same_unit("kPa", "KPA") and not same_unit("kPa", "Pa")


def test_unknown_unit_names_channel_and_unit():
    with pytest.raises(InputError) as err:
        to_si([1.0], "furlong", file="run.csv", channel="SLIPANGL")
    assert str(err.value) == "run.csv: SLIPANGL: unknown unit 'furlong'"


def test_wrong_dimension():
    assert unit_problem("kPa", "angle") == ("unit 'kPa' is a pressure unit, expected an angle "
                                            "unit such as 'rad'")
    with pytest.raises(InputError, match="SLIPANGL: unit 'kN' is a force unit"):
        to_si([1.0], "kN", dimension="angle", channel="SLIPANGL")


def test_every_dimension_has_an_si_unit_with_factor_one():
    for dim in {entry[2] for entry in UNITS.values()}:
        assert UNITS[normalize_unit(SI_UNITS[dim])][:2] == (1.0, 0.0), dim
