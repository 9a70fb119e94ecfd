"""The tyre a measurement folder and a fit are about: identity and nominal operating point.

Read from the ``[tyre]`` table of ``tyre.toml`` (:mod:`identify.io.manifest`) and recorded in
fit.json and discovery.json; kept in core so that every layer can use it.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from identify.core.serial import Serial, from_data

__all__ = ["TyreInfo"]


@dataclass(frozen=True)
class TyreInfo(Serial):
    """The ``[tyre]`` table: identity and nominal operating point [SI].

    Attributes
    ----------
    id : str
    nominal_pressure_Pa : float   [Pa]
    nominal_load_N : float        [N]
    unloaded_radius_m : float     [m] (NaN when unknown, e.g. a single characteristics CSV)
    source : str                  "measured" or "simulated"
    size, description : str
    """

    id: str
    nominal_pressure_Pa: float
    nominal_load_N: float
    unloaded_radius_m: float
    source: str = "measured"
    size: str = ""
    description: str = ""

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TyreInfo:
        """Inverse of :meth:`to_dict` (an unknown number, NaN, is written as null); a
        missing number reads as unknown (NaN), a missing text as its default. Raises
        TypeError without ``id``."""
        return from_data(cls, {**_UNKNOWN_NUMBERS, **d})


_UNKNOWN_NUMBERS: Mapping[str, Any] = dict.fromkeys(
    ("nominal_pressure_Pa", "nominal_load_N", "unloaded_radius_m"))
"""The numbers of the ``[tyre]`` table as unknown (null): what a record without them holds."""
