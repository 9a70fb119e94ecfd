"""The parameter table: every .tir key as data (``parameter_table.csv``).

One row per key that MFeval's ``readTIR`` knows (284 keys, MFeval naming: the tyre mass of
``[INERTIA]`` is ``MASS1`` and is written back as ``MASS``), plus mfid's own ``MFID_EXTENSIONS``.
The .tir reader and writer, the fit set-up and the report's parameter table all read it.

Columns of the CSV (and fields of :class:`ParameterSpec`):

``name``
    The key (upper case, MFeval naming).
``section``
    The .tir section; :data:`SECTIONS` gives their write order.
``default``
    The value MFeval's ``readTIR`` pre-loads when the key is missing (docs/tir-files.md),
    a float or a string without quotes. Deviations, all for keys whose MFeval default is a
    meaningless placeholder: ``FITTYP`` is 61 here (MFeval pre-loads 0, which it rejects; the
    reader requires FITTYP in every file anyway), ``FILE_TYPE``/``FILE_FORMAT`` are 'tir'/'ASCII'
    and the ``[UNITS]`` keys are the SI names (MFeval pre-loads 'default' and assumes SI).
``dimension``
    Physical dimension used for unit conversion, a product of powers of ``L`` (length), ``F``
    (force), ``M`` (mass), ``T`` (time), ``A`` (angle) and ``P`` (pressure), e.g. ``F*T/L`` or
    ``M*L^2``; ``1`` for dimensionless and ``str`` for strings. The Magic Formula coefficients
    (P*, Q*, R*, S*, Q_*), the scaling factors L* and the other shape coefficients are
    dimensionless by TNO convention: they are defined for SI inputs (N, m, rad, Pa) and are never
    converted, whatever ``[UNITS]`` says.
``lower``, ``upper``
    Fit bounds, or None (unbounded). The pressure-relation bounds come from the thesis
    (docs/relations.md); the others are broad physical ranges.
``vary``
    The key may be freed by a fit at all (model coefficients, scaling factors, stiffnesses).
    False for header, model switches, units, dimensions, inertia and validity ranges.
``fit_default_vary``
    A fit frees it by default: MF coefficients yes; scaling factors L*, turn-slip coefficients,
    MF 5.2-only keys, PCFX2/PCFY2 (0 in normal use) and the Swift dynamics no.
``meaning``
    One line, with the unit in brackets.
``magnitude_bounds``
    ``lower``/``upper`` bound the magnitude; the sign follows the start value (PDX1, PDY1, PKY1,
    PKY4, whose sign depends on the file's sign convention). See :func:`bounds`.
``write_for``
    FITTYPs whose files always contain the key (``61 62``, or ``62`` for the MF 6.2-only keys).
    Keys with an empty ``write_for`` (MF 5.2-only keys, FUNCTION_NAME, SWITCH_INTEG), and 6.2-only
    keys in a 6.1 file, are written only when they differ from the default.

The ``MFID_EXTENSIONS`` section holds coefficients that the Magic Formula has no key for; other
tools ignore the section. In a .tir file their keys carry the prefix ``MFID_`` (``MFID_F_X``,
``MFID_CMZ_FORM``) so that they cannot collide with a key of a present or future MF version;
the reader also takes the bare names older mfid versions wrote. All defaults are neutral (they
reproduce plain MF-Swift):

- ``F_X, F_Y, F_Z, F_THETA, F_GAMMA, F_PSI``: linear pressure scaling of the rigid-ring sidewall
  stiffnesses, ``c_b = c_b0 * (1 + f * dpi)`` (op het Veld 2007); default 0.
- ``PCMZ2, PCMZ3``: the quadratic-load and pressure terms of the yaw stiffness in form T2,
  ``CMz = CMz0 * (PCMZ1*Fz/Fz0 + PCMZ2*(Fz/Fz0)^2) * (1 + PCMZ3*dpi)``; default 0.
- ``CMZ_FORM``: 1 = form T1 ``CMz = CMz0 * (1 + PCMZ1*dpi) * Fz/Fz0`` (default), 2 = form T2.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from importlib.resources import files

__all__ = ["ParameterSpec", "PARAMETERS", "SECTIONS", "PRESSURE_KEYS", "STRING_KEYS",
           "spec", "defaults", "bounds", "section_keys", "tir_name",
           "EXTENSION_PREFIX"]

#: Section write order: the 21 MF 6.x sections, then mfid's own section.
SECTIONS: tuple[str, ...] = (
    "MDI_HEADER", "UNITS", "MODEL", "DIMENSION", "OPERATING_CONDITIONS", "INERTIA", "VERTICAL",
    "STRUCTURAL", "CONTACT_PATCH", "INFLATION_PRESSURE_RANGE", "VERTICAL_FORCE_RANGE",
    "LONG_SLIP_RANGE", "SLIP_ANGLE_RANGE", "INCLINATION_ANGLE_RANGE", "SCALING_COEFFICIENTS",
    "LONGITUDINAL_COEFFICIENTS", "OVERTURNING_COEFFICIENTS", "LATERAL_COEFFICIENTS",
    "ROLLING_COEFFICIENTS", "ALIGNING_COEFFICIENTS", "TURNSLIP_COEFFICIENTS", "MFID_EXTENSIONS",
)

#: The MF 6.1 inflation-pressure keys (identified by the pressure relations).
PRESSURE_KEYS: tuple[str, ...] = ("PPX1", "PPX2", "PPX3", "PPX4", "PPY1", "PPY2", "PPY3", "PPY4",
                                  "PPY5", "PPZ1", "PPZ2", "PPMX1", "QSY7", "QSY8", "PFZ1")


@dataclass(frozen=True)
class ParameterSpec:
    """One row of the parameter table (see the module docstring for the columns).

    Attributes
    ----------
    name : str
        Key, MFeval naming (``MASS1`` for the tyre mass).
    section : str
        .tir section.
    default : float or str
        MFeval default (SI for dimensional keys).
    dimension : str
        Dimension expression (``"F/L"``), ``"1"`` or ``"str"``.
    lower, upper : float or None
        Fit bounds (SI), None = unbounded.
    vary : bool
        May be freed by a fit.
    fit_default_vary : bool
        Freed by a fit by default.
    meaning : str
        One line with the unit in brackets.
    magnitude_bounds : bool
        The bounds apply to the magnitude; the sign follows the value.
    write_for : tuple of int
        FITTYPs whose files always contain the key.
    """

    name: str
    section: str
    default: float | str
    dimension: str
    lower: float | None
    upper: float | None
    vary: bool
    fit_default_vary: bool
    meaning: str
    magnitude_bounds: bool
    write_for: tuple[int, ...]

    @property
    def is_string(self) -> bool:
        """True for string-valued keys (``TYRESIDE``, the ``[UNITS]`` names ...)."""
        return self.dimension == "str"

    @property
    def tir_key(self) -> str:
        """The key as written in a .tir file (``MASS`` for ``MASS1``, ``MFID_F_X`` for
        ``F_X``)."""
        return tir_name(self.name)


EXTENSION_PREFIX = "MFID_"
"""Prefix of the .tir keys of the ``MFID_EXTENSIONS`` section."""


def tir_name(name: str) -> str:
    """The .tir spelling of a table name: ``MASS1`` -> ``MASS``, an extension ``F_X`` ->
    ``MFID_F_X``, others unchanged."""
    if name == "MASS1":
        return "MASS"
    if name in _EXTENSIONS:
        return EXTENSION_PREFIX + name
    return name


def _opt_float(text: str) -> float | None:
    return float(text) if text.strip() else None


def _load() -> tuple[ParameterSpec, ...]:
    text = files("identify.model").joinpath("parameter_table.csv").read_text(encoding="utf-8")
    out = []
    for row in csv.DictReader(io.StringIO(text)):
        is_str = row["dimension"] == "str"
        out.append(ParameterSpec(
            name=row["name"], section=row["section"],
            default=row["default"] if is_str else float(row["default"]),
            dimension=row["dimension"], lower=_opt_float(row["lower"]),
            upper=_opt_float(row["upper"]), vary=row["vary"] == "1",
            fit_default_vary=row["fit_default_vary"] == "1", meaning=row["meaning"],
            magnitude_bounds=row["magnitude_bounds"] == "1",
            write_for=tuple(int(t) for t in row["write_for"].split()),
        ))
    return tuple(out)


#: Every row of the table, in write order.
PARAMETERS: tuple[ParameterSpec, ...] = _load()
_BY_NAME: dict[str, ParameterSpec] = {p.name: p for p in PARAMETERS}
_EXTENSIONS = frozenset(p.name for p in PARAMETERS if p.section == "MFID_EXTENSIONS")

#: Names of the string-valued keys.
STRING_KEYS: frozenset[str] = frozenset(p.name for p in PARAMETERS if p.is_string)


def spec(name: str) -> ParameterSpec:
    """Return the table row of ``name`` (MFeval naming).

    Raises
    ------
    KeyError
        If ``name`` is not in the table.
    """
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(f"{name!r} is not a key of the mfid parameter table") from None


def defaults() -> dict[str, float | str]:
    """A fresh dict of every key's default (floats in SI, strings without quotes)."""
    return {p.name: p.default for p in PARAMETERS}


def section_keys(section: str) -> tuple[str, ...]:
    """The table names of one section, in write order."""
    return tuple(p.name for p in PARAMETERS if p.section == section)


def bounds(name: str, value: float | None = None) -> tuple[float, float]:
    """Fit bounds of ``name`` as (lower, upper), with +-inf for no bound.

    For keys with ``magnitude_bounds`` a negative ``value`` mirrors the interval, so that
    PKY1 = -15 gets (-150, -1) and PKY1 = 27 gets (1, 150).

    Parameters
    ----------
    name : str
        Table name.
    value : float, optional
        Start value, which sets the sign for magnitude bounds.
    """
    p = spec(name)
    lo = -math.inf if p.lower is None else p.lower
    hi = math.inf if p.upper is None else p.upper
    if p.magnitude_bounds and value is not None and value < 0:
        lo, hi = -hi, -lo
    return lo, hi
