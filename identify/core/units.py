"""Units of measurement channels and manifest values, converted to SI.

One table (:data:`UNITS`) maps a unit name to ``(factor, offset, dimension)`` so that
``SI = value * factor + offset``; one function (:func:`to_si`) applies it. Unit names are
matched after :func:`normalize_unit`: case-insensitive, spaces, ``.`` and ``·`` between unit
symbols read as ``*``, surrounding brackets dropped (``"[N m]"`` -> ``"n*m"``).
"""
from __future__ import annotations

import math
import re
from collections.abc import Mapping
from functools import cache
from pathlib import Path

import numpy as np

from identify.core.errors import InputError

__all__ = ["UNITS", "SI_UNITS", "normalize_unit", "unit_problem", "same_unit", "to_si",
           "unit_factor", "dimension_factor", "DIMENSION_SYMBOLS"]

_DEG = math.pi / 180.0
_LBF = 4.4482216152605
_IN = 0.0254
_PSI = 6894.757293168361


def _names(names: str, factor: float, dimension: str, offset: float = 0.0) -> dict:
    return {n: (factor, offset, dimension) for n in names.split()}


#: SI value of one unit: normalized name -> (factor, offset, dimension); SI = v*factor + offset.
UNITS: dict[str, tuple[float, float, str]] = {
    **_names("- 1 ratio none", 1.0, "ratio"),
    **_names("% percent", 0.01, "ratio"),
    **_names("rad radian radians", 1.0, "angle"),
    **_names("deg degree degrees °", _DEG, "angle"),
    **_names("mrad", 1e-3, "angle"),
    **_names("pa pascal n/m^2 n/m2", 1.0, "pressure"),
    **_names("kpa", 1e3, "pressure"),
    **_names("mpa", 1e6, "pressure"),
    **_names("bar", 1e5, "pressure"),
    **_names("mbar", 1e2, "pressure"),
    **_names("psi", _PSI, "pressure"),
    **_names("m/s mps", 1.0, "speed"),
    **_names("km/h kph kmh km/hr", 1.0 / 3.6, "speed"),
    **_names("mph", 1609.344 / 3600.0, "speed"),
    **_names("n newton newtons", 1.0, "force"),
    **_names("kn kilonewton kilonewtons", 1e3, "force"),
    **_names("lbf pound_force lb lbs", _LBF, "force"),
    **_names("kgf", 9.80665, "force"),
    **_names("n*m nm m*n n-m", 1.0, "moment"),
    **_names("kn*m knm", 1e3, "moment"),
    **_names("lbf*ft ft*lbf lb*ft ft*lb ft-lb ft-lbf lb-ft lbf-ft", _LBF * 12 * _IN, "moment"),
    **_names("lbf*in in*lbf in-lb in-lbf lb-in lbf-in", _LBF * _IN, "moment"),
    **_names("m meter meters metre metres", 1.0, "length"),
    **_names("mm millimeter millimeters millimetre millimetres", 1e-3, "length"),
    **_names("cm centimeter centimeters centimetre centimetres", 1e-2, "length"),
    **_names("km", 1e3, "length"),
    **_names("in inch inches", _IN, "length"),
    **_names("ft foot feet", 12 * _IN, "length"),
    **_names("kg kilogram kilograms", 1.0, "mass"),
    **_names("g gram grams", 1e-3, "mass"),
    **_names("tonne tonnes", 1e3, "mass"),
    **_names("lbm", 0.45359237, "mass"),
    **_names("s sec second seconds", 1.0, "time"),
    **_names("ms millisecond milliseconds", 1e-3, "time"),
    **_names("min minute minutes", 60.0, "time"),
    **_names("h hour hours", 3600.0, "time"),
    **_names("rad/s", 1.0, "angular_velocity"),
    **_names("deg/s", _DEG, "angular_velocity"),
    **_names("rpm 1/min rev/min", 2.0 * math.pi / 60.0, "angular_velocity"),
    **_names("n/m", 1.0, "stiffness"),
    **_names("n/mm kn/m", 1e3, "stiffness"),
    **_names("kn/mm", 1e6, "stiffness"),
    **_names("n*m/rad nm/rad", 1.0, "torsional_stiffness"),
    **_names("n*m/deg nm/deg", 1.0 / _DEG, "torsional_stiffness"),
    **_names("kn*m/rad knm/rad", 1e3, "torsional_stiffness"),
    **_names("hz 1/s", 1.0, "frequency"),
    **_names("k kelvin", 1.0, "temperature"),
    **_names("degc °c deg*c celsius", 1.0, "temperature", 273.15),
    **_names("degf °f deg*f fahrenheit", 5.0 / 9.0, "temperature", 273.15 - 32.0 * 5.0 / 9.0),
}

#: The SI unit written for each dimension.
SI_UNITS: dict[str, str] = {
    "ratio": "-", "angle": "rad", "pressure": "Pa", "speed": "m/s", "force": "N",
    "moment": "N*m", "length": "m", "time": "s", "angular_velocity": "rad/s",
    "stiffness": "N/m", "torsional_stiffness": "N*m/rad", "frequency": "Hz", "temperature": "K",
    "mass": "kg",
}


def normalize_unit(unit: str) -> str:
    """The lookup form of a unit name: ``" [N m] "`` -> ``"n*m"``, ``"N.m"`` -> ``"n*m"``."""
    text = str(unit).strip()
    if len(text) >= 2 and text[0] + text[-1] in ("[]", "()"):
        text = text[1:-1].strip()
    text = text.lower().replace("·", "*").replace("⋅", "*")
    text = " ".join(text.split())
    text = text.replace(" * ", "*").replace(" / ", "/").replace(" ", "*")
    if "." in text and not any(ch.isdigit() for ch in text):
        text = text.replace(".", "*")
    return text


def _a(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def unit_problem(unit: str, dimension: str | None = None) -> str | None:
    """Why ``unit`` cannot be used (for a quantity of ``dimension``), or None if it can."""
    entry = UNITS.get(normalize_unit(unit))
    if entry is None:
        return f"unknown unit '{unit}'"
    if dimension is not None and entry[2] != dimension:
        have, want = entry[2].replace("_", " "), dimension.replace("_", " ")
        return (f"unit '{unit}' is {_a(have)} {have} unit, expected {_a(want)} {want} unit "
                f"such as '{SI_UNITS[dimension]}'")
    return None


def same_unit(a: str, b: str) -> bool:
    """True when two unit names mean the same unit (``"N m"`` and ``"Nm"``)."""
    na, nb = normalize_unit(a), normalize_unit(b)
    return na == nb or (na in UNITS and UNITS.get(na) == UNITS.get(nb))


def to_si(values, unit: str | None, *, dimension: str | None = None,
          file: str | Path | None = None, channel: str | None = None):
    """Convert ``values`` given in ``unit`` to SI.

    Parameters
    ----------
    values : float or array_like
        Values in ``unit``.
    unit : str or None
        Unit name (see :data:`UNITS`); None or ``""`` means the values are SI already.
    dimension : str, optional
        The dimension the quantity must have (``"angle"``, ``"pressure"`` ...); a unit of
        another dimension is an error.
    file, channel : optional
        Named in the error message.

    Returns
    -------
    float or numpy.ndarray
        The SI values (a new array; the input is not modified).

    Raises
    ------
    InputError
        Unknown unit, or a unit of the wrong dimension.
    """
    if unit is None or str(unit).strip() == "":
        return values if np.isscalar(values) else np.array(values, dtype=float)
    why = unit_problem(unit, dimension)
    if why is not None:
        raise InputError(file, why, key=channel)
    factor, offset, _ = UNITS[normalize_unit(unit)]
    if np.isscalar(values):
        return float(values) * factor + offset
    out = np.array(values, dtype=float)
    if factor != 1.0:
        out *= factor
    if offset != 0.0:
        out += offset
    return out


def unit_factor(unit: str, dimension: str) -> float:
    """SI value of one ``unit`` of ``dimension`` (no offset units); KeyError if unknown."""
    factor, offset, dim = UNITS[normalize_unit(unit)]
    if dim != dimension or offset != 0.0:
        raise KeyError(unit)
    return factor


#: Symbols of the dimension expressions of the parameter table (``"F*T/L"``, ``"M*L^2"``).
DIMENSION_SYMBOLS = {"L": "length", "F": "force", "M": "mass", "T": "time", "A": "angle",
                     "P": "pressure"}
_DIM_FACTOR = re.compile(r"([LFMTAP])(?:\^(-?\d+))?")


@cache
def _dimension_powers(dimension: str) -> tuple[tuple[str, int], ...]:
    if dimension == "str":
        raise ValueError("string keys have no dimension")
    powers: dict[str, int] = {}
    numerator, *denominators = dimension.split("/")
    for sign, part in [(1, numerator)] + [(-1, d) for d in denominators]:
        for factor in part.split("*"):
            factor = factor.strip()
            if factor == "1":
                continue
            m = _DIM_FACTOR.fullmatch(factor)
            if m is None:
                raise ValueError(f"bad dimension expression {dimension!r}")
            powers[m.group(1)] = powers.get(m.group(1), 0) + sign * int(m.group(2) or 1)
    return tuple(sorted((k, v) for k, v in powers.items() if v))


def dimension_factor(dimension: str, scales: Mapping[str, float]) -> float:
    """Factor that converts a value of ``dimension`` from file units to SI.

    Parameters
    ----------
    dimension : str
        Dimension expression such as ``"F*T/L"`` or ``"M*L^2"`` (``"1"`` gives 1).
    scales : mapping
        SI value of one file unit per symbol, e.g. ``{"L": 1e-3, "F": 1e3}`` for mm and kN;
        missing symbols count as 1.

    Returns
    -------
    float
        Multiply the file value by this to get SI.
    """
    factor = 1.0
    for symbol, power in _dimension_powers(dimension):
        factor *= scales.get(symbol, 1.0) ** power
    return factor
