"""The tyre a measurement folder and a fit are about: identity and nominal operating point.

Read from the ``[tyre]`` table of ``tyre.toml`` (:mod:`identify.io.manifest`) and recorded in
fit.json and discovery.json; kept in core so that every layer can use it.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from identify.core.jsonsafe import json_safe

__all__ = ["TyreInfo"]


@dataclass(frozen=True)
class TyreInfo:
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

    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe dict (an unknown value, NaN, becomes None)."""
        return json_safe({f.name: getattr(self, f.name) for f in fields(self)})

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TyreInfo:
        """Inverse of :meth:`to_dict`; a missing or null number is NaN, a missing text the
        default. Raises KeyError without ``id``."""
        def number(key: str) -> float:
            v = d.get(key)
            return math.nan if v is None else float(v)

        return cls(id=str(d["id"]), nominal_pressure_Pa=number("nominal_pressure_Pa"),
                   nominal_load_N=number("nominal_load_N"),
                   unloaded_radius_m=number("unloaded_radius_m"),
                   source=str(d.get("source") or "measured"), size=str(d.get("size") or ""),
                   description=str(d.get("description") or ""))
