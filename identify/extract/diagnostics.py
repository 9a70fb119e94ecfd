"""What each extraction step returns: characteristic rows, per-run diagnostics and flags.

Kept apart from the test modules so every test type reports in the same fixed fields
(``extraction.json`` and the PDF report read them).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from identify.core.jsonsafe import json_safe
from identify.core.quantities import QUANTITIES
from identify.core.serial import Serial
from identify.core.units import SI_UNITS

__all__ = ["FLAG_NAMES", "Flag", "RunDiagnostic", "Part", "row", "json_safe"]

#: The flag vocabulary (docs/procedures.md, docs/fit-directory.md).
FLAG_NAMES = ("stick_slip", "short_run", "asymmetry", "spread", "condition")


@dataclass(frozen=True)
class Flag(Serial):
    """A data problem a test engineer should know about.

    Attributes
    ----------
    run : str
        Run id, or a cell label (``camber_p250_fz5000``) for flags about several runs.
    test : str
        Test type.
    flag : str
        One of :data:`FLAG_NAMES`.
    detail : str
        One sentence with the numbers.
    """

    run: str
    test: str
    flag: str
    detail: str

    def __post_init__(self) -> None:
        if self.flag not in FLAG_NAMES:
            raise ValueError(f"unknown flag {self.flag!r}")



@dataclass(frozen=True)
class RunDiagnostic:
    """How one run was turned into a characteristic.

    Attributes
    ----------
    run, test : str
        Run id and test type.
    quantity : str
        Characteristic the run contributes to.
    pi_bar, Fz_N : float
        Cell of the run: pressure [bar] and set load [N].
    start : int
        Start position (0 when unknown).
    value : float
        The run's own estimate, in the quantity's SI unit (NaN when it failed).
    window : tuple of float or None
        Range of the abscissa used (e.g. plank displacement [m], turn-table angle [rad]).
    window_unit : str
        Unit of ``window``.
    n_points : int
        Samples used.
    r2 : float
        Coefficient of determination of the fit [-].
    rmse : float
        Root-mean-square residual of the fit [unit of the fitted signal].
    flags : tuple of str
        Flags raised on this run.
    extra : mapping
        Test-specific numbers (coefficients, 63 % distance, stick-slip score ...).
    """

    run: str
    test: str
    quantity: str
    pi_bar: float
    Fz_N: float
    start: int
    value: float
    window: tuple[float, float] | None = None
    window_unit: str = ""
    n_points: int = 0
    r2: float = math.nan
    rmse: float = math.nan
    flags: tuple[str, ...] = ()
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "extra", MappingProxyType(dict(self.extra)))
        object.__setattr__(self, "flags", tuple(self.flags))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict (NaN as null)."""
        return json_safe({
            "run": self.run, "test": self.test, "quantity": self.quantity,
            "pi_bar": self.pi_bar, "Fz_N": self.Fz_N, "start": self.start, "value": self.value,
            "unit": unit_of(self.quantity),
            "window": None if self.window is None else list(self.window),
            "window_unit": self.window_unit, "n_points": self.n_points,
            "fit": {"r2": self.r2, "rmse": self.rmse}, "flags": list(self.flags),
            "extra": dict(self.extra)})


@dataclass(frozen=True)
class Part:
    """The result of one test type: characteristic rows, per-run diagnostics, flags."""

    rows: tuple[dict, ...] = ()
    diagnostics: tuple[RunDiagnostic, ...] = ()
    flags: tuple[Flag, ...] = ()


def unit_of(quantity: str) -> str:
    """SI unit of a characteristic (characteristic-table spelling)."""
    return SI_UNITS[QUANTITIES[quantity]]


def row(quantity: str, pi_bar: float, Fz_N: float, value: float, *,
        gamma_deg: float = math.nan, Vx_mps: float = math.nan, mode: str = "") -> dict:
    """One record of the characteristic table (docs/loaded-tables.md)."""
    return {"quantity": quantity, "pi_bar": float(pi_bar), "Fz_N": float(Fz_N),
            "value": float(value), "unit": unit_of(quantity), "Vx_mps": float(Vx_mps),
            "gamma_deg": float(gamma_deg), "mode": mode}
