"""Tyre size designations -> the .tir dimensions (WIDTH, ASPECT_RATIO, RIM_RADIUS).

Two designations are understood, with the usual optional prefix (P, LT), speed-rating letter
before the construction letter (ZR) and load/speed suffix (``94V``):

- metric (ISO): ``225/50 R17``: section width 225 mm, aspect ratio 50 %, rim diameter 17 in;
- flotation (inch), as racing and Formula SAE tyres are sold: ``20.5x7.0-13`` or
  ``20.5x7.0 R13``: overall diameter 20.5 in, section width 7.0 in, rim diameter 13 in; the
  aspect ratio is the sidewall height (diameter - rim)/2 over the width.

The nominal unloaded radius follows from both (rim radius + sidewall height) and is given so
that a caller can compare it with a measured one: a size string describes the nominal tyre, a
measured radius the real one.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["TyreSize", "find_tyre_size", "parse_tyre_size", "size_designation"]

_INCH = 0.0254
_METRIC = re.compile(
    r"(?:P|LT)?\s*(?P<w>\d{3})\s*/\s*(?P<a>\d{2,3})\s*(?:Z|V|W|Y|H)?\s*(?:R|D|B|-)\s*"
    r"(?P<r>\d{2}(?:\.\d)?)(?:\s+\S+)?", re.IGNORECASE)
_FLOTATION = re.compile(
    r"(?P<d>\d{1,2}(?:\.\d+)?)\s*[xX]\s*(?P<w>\d{1,2}(?:\.\d+)?)\s*(?:-|R|\s)\s*R?\s*"
    r"(?P<r>\d{1,2}(?:\.\d+)?)(?:\s+\S+)?")


@dataclass(frozen=True)
class TyreSize:
    """A parsed size designation [SI].

    Attributes
    ----------
    text : str                  the designation as given
    width_m : float             nominal section width [m] (.tir WIDTH)
    aspect_ratio : float        sidewall height / section width [-] (.tir ASPECT_RATIO)
    rim_radius_m : float        nominal rim radius [m] (.tir RIM_RADIUS)
    """

    text: str
    width_m: float
    aspect_ratio: float
    rim_radius_m: float

    @property
    def unloaded_radius_m(self) -> float:
        """Nominal unloaded radius: rim radius + sidewall height [m]."""
        return self.rim_radius_m + self.aspect_ratio * self.width_m

    def tir_values(self) -> dict[str, float]:
        """The .tir [DIMENSION] keys this size determines."""
        return {"WIDTH": self.width_m, "ASPECT_RATIO": self.aspect_ratio,
                "RIM_RADIUS": self.rim_radius_m}


def _um(length_m: float) -> float:
    """A length from inches rounded to 0.1 um, which every whole or tenth inch is exactly:
    RIM_RADIUS 0.2159, not the product's 0.21589999999999998 in the .tir."""
    return round(length_m, 7)


def parse_tyre_size(text: str) -> TyreSize | None:
    """Parse a size designation (see the module docstring); None if it is neither form or its
    numbers make no tyre (aspect ratio outside 0.1-1.5, rim not inside the tyre)."""
    s = " ".join(str(text).split())
    m = _METRIC.fullmatch(s)
    if m:
        width = int(m["w"]) / 1000.0
        size = TyreSize(s, width, int(m["a"]) / 100.0, _um(float(m["r"]) * _INCH / 2.0))
    else:
        m = _FLOTATION.fullmatch(s)
        if not m:
            return None
        diameter, width, rim = float(m["d"]), float(m["w"]), float(m["r"])
        if not diameter > rim > 0 or width <= 0:
            return None
        size = TyreSize(s, _um(width * _INCH), (diameter - rim) / 2.0 / width,
                        _um(rim * _INCH / 2.0))
    return size if 0.1 <= size.aspect_ratio <= 1.5 else None


def size_designation(width_m: float, aspect_ratio: float, rim_radius_m: float) -> str | None:
    """The metric designation (``225/50 R17``) of .tir dimensions [m, -, m], or None when
    they are not a metric size (width not a whole number of mm, aspect ratio not a whole
    percentage, rim diameter not a whole or half inch). Inverse of :func:`parse_tyre_size`."""
    width_mm = width_m * 1000.0
    ratio_pct = aspect_ratio * 100.0
    rim_in = 2.0 * rim_radius_m / _INCH
    if not (abs(width_mm - round(width_mm)) < 1e-6 and abs(ratio_pct - round(ratio_pct)) < 1e-6
            and abs(2 * rim_in - round(2 * rim_in)) < 1e-6 and 100 <= round(width_mm) <= 999):
        return None
    rim = f"{round(2 * rim_in) / 2:g}"
    text = f"{round(width_mm)}/{round(ratio_pct)} R{rim}"
    return text if parse_tyre_size(text) is not None else None


def find_tyre_size(text: str) -> TyreSize | None:
    """The first size designation inside a longer text (a TTC ``tireid`` such as
    ``"Hoosier 20.5x7.0-13 -- Tire 37"``), or None: every run of one to three words is tried
    with :func:`parse_tyre_size`, the longest first."""
    words = str(text).replace(",", " ").split()
    for start in range(len(words)):
        for length in (3, 2, 1):
            if start + length <= len(words):
                size = parse_tyre_size(" ".join(words[start:start + length]))
                if size is not None:
                    return size
    return None
