"""The result of one fit: a small frozen dataclass with fixed fields and ``to_dict()``."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np


def _num(x: float) -> float | None:
    """JSON-safe float (None for NaN/inf)."""
    x = float(x)
    return x if np.isfinite(x) else None


@dataclass(frozen=True)
class MCMCSummary:
    """Posterior summary from emcee, kept apart from the least-squares optimum.

    Attributes
    ----------
    median, q16, q84, q025, q975 : Mapping[str, float]   posterior quantiles per parameter
    tau : Mapping[str, float]       integrated autocorrelation time per parameter [steps]
    acceptance : float              mean acceptance fraction
    n_walkers, n_steps, n_discard, n_thin, n_samples : int
    correlations : Mapping[str, float]   "a|b" -> posterior correlation
    noise : Mapping[str, float]     the noise model's parameters (sigma, AR(1) phi)
    seed : int
    converged : bool                chain longer than 50 tau for every parameter
    chain_file : str or None
    """

    median: Mapping[str, float]
    q16: Mapping[str, float]
    q84: Mapping[str, float]
    q025: Mapping[str, float]
    q975: Mapping[str, float]
    tau: Mapping[str, float]
    acceptance: float
    n_walkers: int
    n_steps: int
    n_discard: int
    n_thin: int
    n_samples: int
    correlations: Mapping[str, float]
    noise: Mapping[str, float]
    seed: int
    converged: bool
    seconds: float
    chain_file: str | None = None
    samples: np.ndarray | None = field(default=None, repr=False, compare=False)

    def interval(self, name: str, level: float = 0.95) -> tuple[float, float]:
        if level == 0.95:
            return self.q025[name], self.q975[name]
        if level == 0.68:
            return self.q16[name], self.q84[name]
        if self.samples is None:
            raise ValueError("samples not kept")
        names = list(self.median)
        col = self.samples[:, names.index(name)]
        lo = (1 - level) / 2
        return float(np.quantile(col, lo)), float(np.quantile(col, 1 - lo))

    def to_dict(self) -> dict[str, Any]:
        d = {k: getattr(self, k) for k in ("acceptance", "n_walkers", "n_steps", "n_discard",
                                           "n_thin", "n_samples", "seed", "converged",
                                           "seconds", "chain_file")}
        for k in ("median", "q16", "q84", "q025", "q975", "tau", "correlations", "noise"):
            d[k] = {n: _num(v) for n, v in getattr(self, k).items()}
        d["effective_samples"] = _num(self.n_samples)
        return d


@dataclass(frozen=True)
class FitResult:
    """One fitted relation or MF stage.

    Attributes
    ----------
    relation, form, objective : str
    parameters : Mapping[str, float]        every parameter (free and fixed) at the optimum
    free : tuple of str                     the fitted ones
    stderr : Mapping[str, float]            standard errors of the free parameters
    bounds : Mapping[str, tuple]            (lower, upper) of the free parameters
    at_bound : tuple of str                 free parameters sitting on a bound
    active_constraints : tuple of str       general constraints that are active (= 0)
    error_total_pct : float                 thesis total error [%] (mean over pressures)
    error_by_pressure_pct : Mapping[float, float]   thesis error per pressure [bar -> %]
    wls : float                             sum of squared weighted residuals
    n_points : int
    converged : bool
    message : str                           the best start's solver message
    n_starts, starts_at_best : int          multi-start global search statistics
    correlations : Mapping[str, float]      "a|b" -> correlation of the estimates
    predicted, measured, pressure_bar : ndarray  per point (kept for CSVs and reports)
    seconds : float                         wall time of the fit [s]
    mcmc : MCMCSummary or None
    nfev : int                              model evaluations of the whole search (every start,
                                            Jacobians included), as scipy's OptimizeResult counts
    status : int                            the best start's solver status (scipy's codes:
                                            > 0 converged, 0 budget exhausted, < 0 failed)
    """

    relation: str
    form: str
    objective: str
    parameters: Mapping[str, float]
    free: tuple[str, ...]
    stderr: Mapping[str, float]
    bounds: Mapping[str, tuple[float, float]]
    at_bound: tuple[str, ...]
    active_constraints: tuple[str, ...]
    error_total_pct: float
    error_by_pressure_pct: Mapping[float, float]
    wls: float
    n_points: int
    converged: bool
    message: str
    n_starts: int
    starts_at_best: int
    correlations: Mapping[str, float]
    predicted: np.ndarray = field(repr=False, compare=False)
    measured: np.ndarray = field(repr=False, compare=False)
    pressure_bar: np.ndarray = field(repr=False, compare=False)
    seconds: float = 0.0
    mcmc: MCMCSummary | None = None
    nfev: int = 0
    status: int = 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict in the fit.json schema."""
        return {
            "relation": self.relation, "form": self.form, "objective": self.objective,
            "parameters": {k: _num(v) for k, v in self.parameters.items() if k in self.free},
            "fixed": {k: _num(v) for k, v in self.parameters.items() if k not in self.free},
            "stderr": {k: _num(v) for k, v in self.stderr.items()},
            "bounds": {k: [_num(a), _num(b)] for k, (a, b) in self.bounds.items()},
            "at_bound": list(self.at_bound),
            "active_constraints": list(self.active_constraints),
            "error_total_pct": _num(self.error_total_pct),
            "error_by_pressure_pct": {f"{k:g}": _num(v)
                                      for k, v in self.error_by_pressure_pct.items()},
            "wls": _num(self.wls), "n_points": self.n_points, "converged": self.converged,
            "message": self.message, "n_starts": self.n_starts,
            "starts_at_best": self.starts_at_best,
            "correlations": {k: _num(v) for k, v in self.correlations.items()},
            "seconds": self.seconds, "nfev": self.nfev, "status": self.status,
            "mcmc": None if self.mcmc is None else self.mcmc.to_dict(),
        }

    def report(self) -> str:
        """Plain-text summary (parameters, errors, search statistics)."""
        lines = [f"{self.relation} [{self.form}], objective {self.objective}: "
                 f"total thesis error {self.error_total_pct:.3f} %"
                 f" ({'converged' if self.converged else 'NOT converged: ' + self.message})",
                 f"  global search: {self.starts_at_best}/{self.n_starts} starts at the best value"]
        for p, e in self.error_by_pressure_pct.items():
            lines.append(f"  {p:5.2f} bar: {e:.3f} %")
        for n in self.free:
            flag = "  (at bound)" if n in self.at_bound else ""
            lines.append(f"  {n:>10} = {self.parameters[n]: .6g} +/- {self.stderr[n]:.2g}{flag}")
        if self.active_constraints:
            lines.append("  active constraints: " + ", ".join(self.active_constraints))
        return "\n".join(lines)
