"""Physical plausibility of measured and declared values, in SI, after every unit conversion.

One table of ranges, used by every reader (tyre.toml, trailer CSV/HDF5/TYDEX/TTC, flatplank,
characteristic tables, operating points, .tir): a value is checked *after* its unit
conversion and any channel factor, so that ``1e308 kPa`` (infinite in Pa) or a TYDEX factor
that overflows is caught, and every threshold is in SI.

Each quantity has an error band (the value cannot be that quantity: the input is refused) and
a warning band (possible but unusual, or the sign of a unit mix-up: reported, kept).

==========  ======  ==================  ==================================================
quantity    unit    error               warning
==========  ======  ==================  ==================================================
pressure    Pa      < 1 Pa or > 5 MPa   < 1000 Pa (bar or kPa given as Pa?), > 1.5 MPa
load        N       < 0 or > 1 MN       > 100 kN
radius      m       < 1 cm or > 5 m     outside 0.1 .. 1.5 m
speed       m/s     abs > 500 m/s       abs > 100 m/s (km/h given as m/s?)
angle       rad     abs > 2 pi          abs > pi/2 (degrees given as radians?)
force       N       abs > 1 MN          abs > 100 kN
moment      N m     abs > 1 MN m        abs > 50 kN m
slip        -       abs > 1000          abs > 2 (a slip ratio in percent?)
time        s       abs > 1e10 s        (a time stamp: Unix time is 1.7e9 s)
time_step   s       <= 1e-7 s, > 1 h    < 0.1 ms, > 10 s
magnitude   SI      abs > 1e12          (a characteristic value: finite and not absurd)
==========  ======  ==================  ==================================================

Aircraft tyres run at up to about 2 MPa and 200 kN, mining tyres have radii near 2 m: the
error bands leave room for every tyre; the warning bands frame road-vehicle tyres, from a
Formula Student tyre at 0.2 kN to a truck tyre at 50 kN (whose overturning moment about the
wheel centre reaches tens of kN m). A rig logs at 1 Hz (a slow Flatplank) to a few kHz: a
sample interval below 0.1 us or above an hour is a unit mix-up or not a time channel.
Measured channels (:func:`judge_channel`) are judged on their typical level (the median) or,
for the quantities in :data:`LARGEST`, on their largest magnitude: a force or a slip ratio
is centred near zero, and one sample of 1e300 N is no force whatever the others say.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Band", "BANDS", "LARGEST", "Finding", "first_error", "judge", "judge_channel"]


@dataclass(frozen=True)
class Band:
    """Plausible range of one quantity [SI]; ``low_*``/``high_*`` None: no bound.

    A value is an error when ``value < error_low`` (``<=`` when ``strict_low``) or
    ``value > error_high``; a warning when outside ``warn_low .. warn_high``. With ``absolute``
    the bounds apply to ``abs(value)``.
    """

    unit: str
    error_low: float | None
    warn_low: float | None
    warn_high: float | None
    error_high: float | None
    strict_low: bool = False
    absolute: bool = False
    hint_low: str = ""
    hint_high: str = ""


BANDS: dict[str, Band] = {
    "pressure": Band("Pa", 1.0, 1000.0, 1.5e6, 5e6, hint_low="bar or kPa given as Pa?"),
    "load": Band("N", 0.0, None, 1e5, 1e6),
    "radius": Band("m", 0.01, 0.1, 1.5, 5.0),
    "speed": Band("m/s", None, None, 100.0, 500.0, absolute=True,
                  hint_high="km/h given as m/s?"),
    "angle": Band("rad", None, None, math.pi / 2, 2 * math.pi, absolute=True,
                  hint_high="degrees given as radians?"),
    "force": Band("N", None, None, 1e5, 1e6, absolute=True),
    "moment": Band("N m", None, None, 5e4, 1e6, absolute=True),
    "slip": Band("", None, None, 2.0, 1e3, absolute=True,
                 hint_high="a slip ratio in percent?"),
    "time": Band("s", None, None, None, 1e10, absolute=True),
    "time_step": Band("s", 1e-7, 1e-4, 10.0, 3600.0, strict_low=True,
                      hint_low="not a time channel, or a unit mix-up?"),
    "magnitude": Band("", None, None, None, 1e12, absolute=True),
}

#: Quantities whose measured channel is judged on its largest magnitude, not its median.
LARGEST = frozenset({"angle", "force", "moment", "slip", "time"})


@dataclass(frozen=True)
class Finding:
    """One implausible value: ``level`` is ``"error"`` or ``"warning"``; ``message`` says what
    and why in a few words (no file, key or line: the caller names those)."""

    level: str
    message: str

    @property
    def is_error(self) -> bool:
        return self.level == "error"


def _fmt(value: float, unit: str) -> str:
    return f"{value:.6g} {unit}".rstrip()


def judge(quantity: str, value: float, *, what: str = "") -> Finding | None:
    """Check one value [SI] against the band of ``quantity`` (see the module table).

    Parameters
    ----------
    quantity : str
        A key of :data:`BANDS`.
    value : float
        The value in SI units (after the unit conversion).
    what : str
        How to name the value in the message (default: the quantity); ``"median "`` ...

    Returns
    -------
    Finding or None
        None when plausible.
    """
    band = BANDS[quantity]
    name = what or quantity
    try:
        value = float(value)
    except (OverflowError, ValueError, TypeError):
        return Finding("error", f"{name} is not a number")
    if not math.isfinite(value):
        return Finding("error", f"{name} is {value} in SI (not finite after the unit "
                                "conversion)")
    x = abs(value) if band.absolute else value
    shown = _fmt(value, band.unit)
    if band.error_low is not None and (x <= band.error_low if band.strict_low
                                       else x < band.error_low):
        rel = "> " if band.strict_low else ">= "
        return Finding("error", f"{name} {shown} is not physical (must be {rel}"
                                f"{_fmt(band.error_low, band.unit)})")
    if band.error_high is not None and x > band.error_high:
        return Finding("error", f"{name} {shown} is not physical (at most "
                                f"{_fmt(band.error_high, band.unit)}{_hint(band.hint_high)})")
    low = band.warn_low is not None and x < band.warn_low
    if low or (band.warn_high is not None and x > band.warn_high):
        bound, side, hint = ((band.warn_low, "low (below", band.hint_low) if low
                             else (band.warn_high, "high (above", band.hint_high))
        return Finding("warning", f"{name} {shown} is unusually {side} "
                                  f"{_fmt(bound, band.unit)}{_hint(hint)})")
    return None


def _hint(text: str) -> str:
    return f"; {text}" if text else ""


def judge_channel(quantity: str, values: np.ndarray, *, what: str = "",
                  median: float | None = None) -> tuple[Finding, int | None] | None:
    """Check a measured channel [SI]: its typical level against the band of ``quantity``.

    Pressure, load, radius and speed are judged on the median of the finite samples (one
    noisy sample does not make a channel implausible; ``median``: that median [SI] when the
    caller has it, not computed again); the quantities of :data:`LARGEST` on the largest
    magnitude (a sweep to 15 'rad' is degrees, whatever its median; a force channel's median
    is near zero). Returns the finding and the position of the sample concerned (None for a
    median), or None.
    """
    largest = quantity in LARGEST
    if median is None or largest:
        x = np.asarray(values, dtype=np.float64)
        finite = np.isfinite(x)
        if not finite.any():
            return None  # the quirk checks report a channel without a finite value
        whole = bool(finite.all())
        x = x if whole else x[finite]
        if largest:
            i = int(np.argmax(np.abs(x)))
            found = judge(quantity, float(x[i]), what=what or f"largest {quantity}")
            if found is None:
                return None
            return found, (i if whole else int(np.flatnonzero(finite)[i]))
        median = float(np.median(x))
    found = judge(quantity, median, what=what or f"median {quantity}")
    return None if found is None else (found, None)


def first_error(quantity: str, values: np.ndarray, *, what: str = "",
                allow_zero: bool = False) -> tuple[int, Finding] | None:
    """The first sample [SI] in the error band of ``quantity`` (vectorised), or None.

    ``allow_zero`` accepts exactly 0 where the band's lower bound is strict (a pressure of 0
    in an operating-point table means "the .tir's INFLPRES")."""
    band = BANDS[quantity]
    x = np.asarray(values, dtype=np.float64)
    a = np.abs(x) if band.absolute else x
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(x)
        if band.error_high is not None:
            bad |= a > band.error_high
        if band.error_low is not None:
            bad |= (a <= band.error_low) if band.strict_low else (a < band.error_low)
            if allow_zero:
                bad &= x != 0.0
    hits = np.flatnonzero(bad)
    if hits.size == 0:
        return None
    i = int(hits[0])
    return i, judge(quantity, float(x[i]), what=what)
