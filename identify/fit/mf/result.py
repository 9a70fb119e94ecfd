"""The result of the staged MF fit (identify.fit.mf.stages.fit_mf)."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from identify.fit.mf.stage_specs import STAGES
from identify.fit.result import FitResult

__all__ = ["MFFit", "point_columns", "CSV_COLUMNS"]

CSV_COLUMNS = ("relation", "form", "quantity", "unit", "pi_bar", "Fz_N", "gamma_deg",
               "alpha_rad", "kappa", "Vx_mps", "measured", "model")
"""Columns of measured_vs_model.csv (docs/fit-directory.md)."""


def point_columns(points: pd.DataFrame) -> dict[str, np.ndarray]:
    """The operating-point columns of measured_vs_model.csv from a trailer table."""
    return {"Fz_N": points["Fz"].to_numpy(float),
            "gamma_deg": np.rad2deg(points["gamma"].to_numpy(float)),
            "alpha_rad": points["alpha"].to_numpy(float),
            "kappa": points["kappa"].to_numpy(float),
            "Vx_mps": points["Vx"].to_numpy(float)}


@dataclass(frozen=True)
class MFFit:
    """Result of the staged MF fit.

    Attributes
    ----------
    params : Mapping[str, float]   every .tir value after all stages (write with write_tir)
    results : tuple of FitResult   one per fitted stage, in order (relation "MF", form = stage)
    held : Mapping[str, Mapping[str, str]]   stage -> {coefficient: why it was held}
    skipped : Mapping[str, str]    stage -> why it was not fitted (no points)
    settings : Mapping[str, Any]   seed, fittyp, use_mode, n_lhs, max_nfev, passes, stages,
                                   screen, objective
    points : Mapping[str, DataFrame]   stage -> its operating points (Fz, kappa, alpha, gamma,
                                   Vx, p; geometry also omega), row for row with the stage's
                                   FitResult arrays
    seconds : float                wall time of the whole fit [s]
    """

    params: Mapping[str, float]
    results: tuple[FitResult, ...]
    held: Mapping[str, Mapping[str, str]]
    skipped: Mapping[str, str]
    settings: Mapping[str, Any]
    points: Mapping[str, pd.DataFrame] = field(repr=False, compare=False, default_factory=dict)
    seconds: float = 0.0

    @property
    def keys_fitted(self) -> tuple[str, ...]:
        """Every coefficient some stage freed, in stage order."""
        return tuple(n for r in self.results for n in r.free)

    def result(self, stage: str) -> FitResult:
        """The FitResult of ``stage``."""
        for r in self.results:
            if r.form == stage:
                return r
        raise KeyError(f"stage {stage!r} was not fitted")

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe summary: settings, fitted keys, held and skipped, one FitResult per stage."""
        return {"settings": dict(self.settings), "keys_fitted": list(self.keys_fitted),
                "parameters": {k: float(self.params[k]) for k in self.keys_fitted},
                "held": {k: dict(v) for k, v in self.held.items()},
                "skipped": dict(self.skipped), "seconds": self.seconds,
                "fits": [r.to_dict() for r in self.results]}

    @property
    def csv_frames(self) -> tuple[pd.DataFrame, ...]:
        """One measured_vs_model table per stage (columns CSV_COLUMNS)."""
        frames = []
        for r in self.results:
            sd = STAGES[r.form]
            frames.append(pd.DataFrame({
                "relation": r.relation, "form": r.form, "quantity": sd.quantity,
                "unit": sd.unit, "pi_bar": r.pressure_bar, **point_columns(self.points[r.form]),
                "measured": r.measured, "model": r.predicted}, columns=list(CSV_COLUMNS)))
        return tuple(frames)

    def measured_vs_model(self) -> pd.DataFrame:
        """One row per fitted point of every stage (columns CSV_COLUMNS)."""
        frames = self.csv_frames
        return (pd.concat(frames, ignore_index=True) if frames
                else pd.DataFrame(columns=list(CSV_COLUMNS)))

    def report(self) -> str:
        """Plain text: every stage's FitResult.report() and what was held."""
        out = []
        for r in self.results:
            out.append(r.report())
            for n, why in self.held.get(r.form, {}).items():
                out.append(f"  held {n:>6} = {self.params[n]: .6g}  ({why})")
        for s, why in self.skipped.items():
            out.append(f"MF [{s}] skipped: {why}")
        return "\n".join(out)
