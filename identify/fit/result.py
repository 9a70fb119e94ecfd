"""The result of one fit: small frozen dataclasses that round-trip through fit.json.

``FitResult.to_dict()`` is one entry of fit.json's ``fits`` list and ``FitResult.from_dict``
reads it back: ``FitResult.from_dict(r.to_dict()).to_dict() == r.to_dict()``. A number JSON
cannot hold (NaN, infinity) is written as null and read back as NaN (an open bound as -inf or
+inf). The per-point arrays (``predicted``, ``measured``, ``pressure_bar``) are not in fit.json
but in measured_vs_model.csv: ``from_dict`` leaves them empty, and
:func:`identify.io.fitdir.read_fit_dir` fills them from the table.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from lmfit import Parameters
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from identify.core.serial import Serial, from_data, meta
from identify.fit.solve.covariance import t_quantile
from identify.fit.status import FAILED

#: Axis labels of the measured_vs_model.csv columns a result's points vary along.
_X_LABELS = {"alpha_rad": "slip angle [deg]", "kappa": "slip ratio [-]", "Fz_N": "load [N]",
             "gamma_deg": "camber [deg]", "pi_bar": "pressure [bar]"}


def _swept_column(rows: pd.DataFrame) -> str:
    """The column the points of a result are swept along: of slip angle, slip ratio, load,
    camber and pressure, the one with the most distinct values."""
    counts = {c: rows[c].round(6).nunique() for c in _X_LABELS
              if c in rows and rows[c].notna().any()}
    return max(counts, key=counts.get) if counts else "pi_bar"


def _lmfit_name(name: str) -> str:
    """A coefficient's name as lmfit accepts it (a Python identifier)."""
    return name if name.isidentifier() else "".join(c if c.isalnum() else "_" for c in name)


def _float(x: Any, missing: float = math.nan) -> float:
    """A number read from JSON: null -> ``missing``."""
    return missing if x is None else float(x)


def _floats(d: Mapping[str, Any] | None) -> dict[str, float]:
    return {str(k): _float(v) for k, v in (d or {}).items()}


_EMPTY = np.empty(0)


@dataclass(frozen=True)
class MCMCSummary(Serial):
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
    stopped : str                   why an unconverged chain stopped: "max_steps" (the step
                                    cap) or "budget" (the time budget); "" when converged
    reparametrised : tuple of str   coordinates sampled in place of some coefficients (e.g.
                                    Kya@3000N for PKY1, PKY2, PKY4, Kya@3000N,1.90bar for
                                    PPY1, PPY2; identify.fit.mcmc.reparam)
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
    seconds: float = field(metadata=meta(null=0.0))
    chain_file: str | None = None
    stopped: str = ""
    reparametrised: tuple[str, ...] = ()
    samples: np.ndarray | None = field(default=None, repr=False, compare=False,
                                       metadata=meta(skip=True))

    #: fit.json's key order (the quantiles and maps follow), then ``effective_samples``
    serial_order = ("acceptance", "n_walkers", "n_steps", "n_discard", "n_thin",
                    "n_samples", "seed", "converged", "seconds", "chain_file", "stopped",
                    "reparametrised")
    serial_derived = {"effective_samples": lambda self: float(self.n_samples)}

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

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> MCMCSummary:
        """Inverse of :meth:`to_dict` (``effective_samples`` is ``n_samples``; the samples
        themselves are not in fit.json: read the chain file). An entry written before a
        field was recorded reads as what such a run did: no correlations or noise
        parameters, 0 s, and a chain that did not converge stopped at the step cap."""
        recorded = {"correlations": {}, "noise": {}, "seconds": 0.0,
                    "stopped": "" if d.get("converged") else "max_steps"}
        return from_data(cls, {**recorded, **d})


@dataclass(frozen=True)
class Rival(Serial):
    """Another local minimum of a fit's objective that the data cannot rule out.

    Attributes
    ----------
    values : Mapping[str, float]   the free coefficients where it differs from the reported
                                   optimum by more than 1.96 of their standard errors
    dchi2 : float                  its objective above the reported one, in chi^2 units on the
                                   scale of the reported intervals (3.84: the edge of a 95 %
                                   region of one coefficient)
    """

    values: Mapping[str, float]
    dchi2: float



RESULT_RECORD_DEFAULTS: Mapping[str, Any] = {
    "objective": "", "fixed": {}, "stderr": {}, "bounds": {}, "at_bound": (),
    "active_constraints": (), "error_total_pct": None, "error_by_pressure_pct": {},
    "wls": None, "n_points": 0, "message": "", "n_starts": 0, "starts_at_best": 0,
    "correlations": {}}
"""Entries of a fit.json ``fits`` item written before they were recorded: what such a fit
had (no objective name, no fixed parameters, standard errors, bounds or correlations, unknown
errors, no counts)."""


@dataclass(frozen=True)
class FitResult(Serial):
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
    identification : str                    "ok" or "poorly identified" (a coefficient at a
                                            bound, an interval wider than its bounds, a
                                            correlation above 0.99, too few points per
                                            coefficient: identify.fit.identifiability)
    reasons : tuple of str                  why it is poorly identified, and what was held
    held : Mapping[str, str]                coefficients the fit would free but held at their
                                            default (``--hold`` or not identifiable) -> why
    covariance : str                        the covariance ``stderr`` comes from
                                            (docs/intervals.md): "iid" (s^2 (J^T J)^-1),
                                            "iid-known-sigma" ((J^T J)^-1, weights 1/sigma),
                                            "sweep-jackknife" (delete-one-sweep jackknife) or
                                            "staged-sweep-jackknife" (the same with the
                                            earlier MF stages' uncertainty:
                                            identify.fit.mf.uncertainty)
    clusters : int                          sweeps of the jackknife (0 for iid)
    unidentified : Mapping[str, str]        free coefficients not identifiable on their own
                                            -> why (at a bound, near-null direction, a
                                            correlation above 0.99:
                                            identify.fit.identifiability.unidentified)
    rivals : tuple of Rival                 other minima within reach of the optimum (the MF
                                            stages' search candidates solved again:
                                            identify.fit.mf.stages; docs/intervals.md)
    conditional : Mapping[str, str]         free coefficients whose value rests on held ones
                                            -> which and how much (the MF stages' holds that
                                            took effect only after the fit:
                                            identify.fit.mf.conditional)
    dof : Mapping[str, float]               degrees of freedom of each standard error
                                            (identify.fit.solve.covariance.interval_dof): the 95 %
                                            interval is value +/- t(0.975, dof) standard
                                            errors (:meth:`interval`); a name without one has
                                            infinite degrees of freedom (1.96)
    profile : Mapping[str, tuple]           (lower, upper) 95 % interval of an identifiable
                                            MF coefficient (identify.fit.mf.profile): value
                                            +/- t standard errors with each end moved out to
                                            the objective's profile where that is flatter
                                            than the quadratic approximation, and stopped at
                                            a bound
    unconstrained_wls : float               r^T r (as ``wls``) at the least-squares optimum
                                            that a constrained polish left to meet the
                                            validity conditions (identify.fit.optimize); NaN
                                            when the optimum is the least-squares one: how
                                            much the conditions cost (identify.fit.
                                            identifiability.problems)
    noise_floor_pct : float                 the error the measurements' own scatter allows
                                            [%] (identify.fit.status.noise_floor); NaN
                                            where the points hold no estimate (a table)
    floor_source : str                      where the floor comes from
    fit_status : str                        the fit's status (identify.fit.status:
                                            ok, poorly identified, poor fit, failed),
                                            weighing its error against the floor and its
                                            identifiability; "" before it is assessed
    """

    relation: str
    form: str
    objective: str
    parameters: Mapping[str, float] = field(metadata=meta(skip=True))
    free: tuple[str, ...] = field(metadata=meta(skip=True))
    stderr: Mapping[str, float]
    bounds: Mapping[str, tuple[float, float]]
    at_bound: tuple[str, ...]
    active_constraints: tuple[str, ...]
    error_total_pct: float
    error_by_pressure_pct: Mapping[float, float] = field(metadata=meta(key_format="g"))
    wls: float
    n_points: int
    converged: bool
    message: str
    n_starts: int
    starts_at_best: int
    correlations: Mapping[str, float]
    predicted: np.ndarray = field(repr=False, compare=False, metadata=meta(skip=True))
    measured: np.ndarray = field(repr=False, compare=False, metadata=meta(skip=True))
    pressure_bar: np.ndarray = field(repr=False, compare=False, metadata=meta(skip=True))
    seconds: float = field(default=0.0, metadata=meta(null=0.0))
    mcmc: MCMCSummary | None = None
    nfev: int = 0
    status: int = 0
    identification: str = "ok"
    reasons: tuple[str, ...] = ()
    held: Mapping[str, str] = field(default_factory=dict)
    covariance: str = "iid"
    clusters: int = 0
    unidentified: Mapping[str, str] = field(default_factory=dict)
    dof: Mapping[str, float] = field(default_factory=dict, metadata=meta(null=math.inf))
    rivals: tuple[Rival, ...] = ()
    conditional: Mapping[str, str] = field(default_factory=dict)
    profile: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    unconstrained_wls: float = math.nan
    noise_floor_pct: float = math.nan
    floor_source: str = ""
    fit_status: str = field(default="", compare=False,  # derived by assess()
                            metadata=meta(skip=True))
    points: Any = field(default=None, repr=False, compare=False, metadata=meta(skip=True))

    #: fit.json writes the free parameters' values (``parameters``) and the others
    #: (``fixed``) in place of :attr:`parameters` and :attr:`free`, and the status as
    #: :attr:`status_text`; the MCMC summary last
    serial_derived = {"parameters": lambda self: _floats(self.fitted),
                      "fixed": lambda self: _floats(self.fixed),
                      "fit_status": lambda self: self.status_text}
    serial_order = ("relation", "form", "objective", "parameters", "fixed", "stderr",
                    "bounds", "at_bound", "active_constraints", "error_total_pct",
                    "error_by_pressure_pct", "wls", "n_points", "converged", "message",
                    "n_starts", "starts_at_best", "correlations", "seconds", "nfev", "status",
                    "identification", "reasons", "held", "covariance", "clusters",
                    "unidentified", "dof", "rivals", "conditional", "profile",
                    "unconstrained_wls", "noise_floor_pct", "floor_source", "fit_status")

    def __repr__(self) -> str:
        state = self.status_text
        return (f"<FitResult {self.name}: {state}, error {self.error_total_pct:.3g} %, "
                f"{len(self.free)} free of {len(self.parameters)}, {self.n_points} points>")

    @property
    def params(self) -> Parameters:
        """The coefficients as ``lmfit.Parameters``: value, ``vary`` (free or held), bounds,
        ``stderr`` and ``correl`` (the correlations of the estimates) in one object."""
        out = Parameters()
        for name, value in self.parameters.items():
            free = name in self.free
            low, high = self.bounds.get(name, (-math.inf, math.inf)) if free else \
                (-math.inf, math.inf)
            value = float(value)
            # lmfit clips a value outside its bounds; a held value keeps open bounds
            out.add(_lmfit_name(name), value=value, vary=free,
                    min=min(low, value), max=max(high, value))
            par = out[_lmfit_name(name)]
            par.stderr = float(self.stderr[name]) if free and name in self.stderr else None
            par.correl = {} if free else None
        for pair, rho in self.correlations.items():
            a, _, b = pair.partition("|")
            for x, y in ((a, b), (b, a)):
                if _lmfit_name(x) in out and out[_lmfit_name(x)].correl is not None:
                    out[_lmfit_name(x)].correl[_lmfit_name(y)] = float(rho)
        return out

    def table(self) -> pd.DataFrame:
        """The free coefficients, one row each: value, standard error, 95 % interval, bounds,
        whether at a bound or not identifiable on its own."""
        rows = []
        for name in self.free:
            low, high = self.interval(name)
            bound = self.bounds.get(name, (-math.inf, math.inf))
            rows.append({"result": self.name, "name": name,
                         "value": float(self.parameters[name]),
                         "stderr": float(self.stderr.get(name, math.nan)),
                         "ci95_low": low, "ci95_high": high, "lower_bound": bound[0],
                         "upper_bound": bound[1], "at_bound": name in self.at_bound,
                         "unidentified": self.unidentified.get(name, "")})
        return pd.DataFrame(rows, columns=["result", "name", "value", "stderr", "ci95_low",
                                           "ci95_high", "lower_bound", "upper_bound",
                                           "at_bound", "unidentified"])

    def _repr_html_(self) -> str:
        head = (f"<p><b>{self.name}</b>: {self.status_text}, total error "
                f"{self.error_total_pct:.3g} %, {self.n_points} points, standard errors "
                f"{self.covariance}</p>")
        return head + self.table().drop(columns="result").to_html(index=False,
                                                                  float_format="{:.4g}".format)

    def plot(self, ax: Axes | None = None) -> Figure:
        """Measured points (markers) and the model at them (dots) against the swept variable,
        one colour per pressure, from the arrays in memory; the residuals below. Returns the
        figure (a new one unless ``ax`` is given)."""
        rows = self.points
        if rows is None or not len(rows):
            raise ValueError(f"{self.name}: no per-point data in memory (a run from "
                             "mfid.fit or FitRun.load has them)")
        x_col = _swept_column(rows)
        x = rows[x_col].to_numpy(float) * (180 / math.pi if x_col == "alpha_rad" else 1.0)
        if ax is None:
            fig = Figure(figsize=(8, 6), layout="constrained")
            ax, res = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
        else:
            fig, res = ax.figure, None
        measured, model = rows["measured"].to_numpy(float), rows["model"].to_numpy(float)
        pressures = rows["pi_bar"].to_numpy(float)
        for k, level in enumerate(np.unique(np.round(pressures, 2))):
            sel = np.round(pressures, 2) == level
            colour = f"C{k % 10}"
            ax.plot(x[sel], measured[sel], "o", mfc="none", color=colour, ms=4,
                    label=f"{level:g} bar measured")
            ax.plot(x[sel], model[sel], ".", color=colour, ms=3, label=f"{level:g} bar model")
            if res is not None:
                res.plot(x[sel], measured[sel] - model[sel], ".", color=colour, ms=3)
        quantity = str(rows["quantity"].iloc[0]) if "quantity" in rows else "value"
        unit = str(rows["unit"].iloc[0]) if "unit" in rows else ""
        ax.set_ylabel(f"{quantity} [{unit}]" if unit else quantity)
        ax.set_title(f"{self.name}: total error {self.error_total_pct:.3g} % "
                     f"({self.status_text})")
        ax.legend(fontsize="small", ncols=2)
        label = _X_LABELS.get(x_col, x_col)
        (res if res is not None else ax).set_xlabel(label)
        if res is not None:
            res.axhline(0.0, color="0.5", lw=0.8)
            res.set_ylabel("measured - model")
        return fig

    def quantile(self, name: str, level: float = 0.95) -> float:
        """Standard errors from the value to the end of the two-sided ``level`` interval of
        ``name``: Student's t at its degrees of freedom (:attr:`dof`; the normal's without)."""
        return t_quantile(self.dof.get(name, math.inf), level)

    def interval(self, name: str, level: float = 0.95) -> tuple[float, float]:
        """The least-squares ``level`` interval of ``name``: its 95 % profile interval where
        one was computed (:attr:`profile`), else value +/- :meth:`quantile` standard errors
        (:meth:`wald_interval`; docs/intervals.md); NaN without a standard error."""
        if level == 0.95 and name in self.profile:
            lo, hi = self.profile[name]
            return float(lo), float(hi)
        return self.wald_interval(name, level)

    def wald_interval(self, name: str, level: float = 0.95) -> tuple[float, float]:
        """value +/- :meth:`quantile` standard errors: the ``level`` interval of the quadratic
        approximation of the objective at the optimum."""
        v = float(self.parameters[name])
        half = self.quantile(name, level) * float(self.stderr.get(name, math.nan))
        return v - half, v + half

    def _quantile_note(self) -> str:
        """"; 95 % intervals +/- 2.05-2.23 s.e. (Student's t)" over the free coefficients
        with finite degrees of freedom; "" without."""
        q = [self.quantile(n) for n in self.free if math.isfinite(self.dof.get(n, math.inf))]
        if not q:
            return ""
        low, high = f"{min(q):.3g}", f"{max(q):.3g}"
        span = low if low == high else f"{low}-{high}"
        return f"; 95 % intervals +/- {span} s.e. (Student's t)"

    @property
    def status_text(self) -> str:
        """The fit's status (identify.fit.status.STATUSES): :attr:`fit_status` once assessed,
        else "failed" (did not converge), "poorly identified" or "ok"."""
        if not self.converged:
            return FAILED
        return self.fit_status or self.identification

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> FitResult:
        """Inverse of :meth:`to_dict`.

        ``parameters`` (the free ones, in order) and ``fixed`` are merged into
        :attr:`parameters`; null numbers are NaN, a null bound is open (-inf, +inf), a null
        ``dof`` infinite. The per-point arrays are empty: they live in measured_vs_model.csv
        (see :func:`identify.io.fitdir.read_fit_dir`). An entry written before a field was
        recorded reads as what such a fit had (:data:`RESULT_RECORD_DEFAULTS`, else the
        field's default): no counts, no messages, iid standard errors, ``fit_status`` ""
        (the status then follows the identification, as before it was recorded). Raises
        TypeError on a malformed entry (the message names the key).
        """
        d = {**RESULT_RECORD_DEFAULTS, **d}
        free = {str(k): _float(v) for k, v in d["parameters"].items()}
        bounds = {str(k): (_float(b[0], -math.inf), _float(b[1], math.inf))
                  for k, b in d["bounds"].items()}
        return from_data(cls, d, parameters={**free, **_floats(d["fixed"])},
                         free=tuple(free), bounds=bounds, predicted=_EMPTY, measured=_EMPTY,
                         pressure_bar=_EMPTY, fit_status=str(d.get("fit_status", "")))

    @property
    def fitted(self) -> dict[str, float]:
        """The free parameters and their values, in :attr:`parameters` order (fit.json's
        ``parameters``)."""
        return {k: v for k, v in self.parameters.items() if k in self.free}

    @property
    def fixed(self) -> dict[str, float]:
        """The parameters held fixed and their values (fit.json's ``fixed``)."""
        return {k: v for k, v in self.parameters.items() if k not in self.free}

    @property
    def name(self) -> str:
        """``relation/form``: the name :meth:`identify.fit.run.FitRun.result` accepts."""
        return f"{self.relation}/{self.form}"

    def report(self) -> str:
        """Plain-text summary (parameters, errors, search statistics)."""
        floor = (f" (noise floor {self.noise_floor_pct:.3g} %)"
                 if math.isfinite(self.noise_floor_pct) else "")
        lines = [f"{self.relation} [{self.form}], objective {self.objective}: "
                 f"total thesis error {self.error_total_pct:.3f} %{floor}, "
                 f"status {self.status_text}"
                 f" ({'converged' if self.converged else 'NOT converged: ' + self.message})",
                 f"  global search: {self.starts_at_best}/{self.n_starts} starts at the best value",
                 f"  standard errors: {self.covariance}"
                 + (f" over {self.clusters} sweeps" if self.clusters else "")
                 + self._quantile_note()]
        for p, e in self.error_by_pressure_pct.items():
            lines.append(f"  {p:5.2f} bar: {e:.3f} %")
        for n in self.free:
            flag = "  (at bound)" if n in self.at_bound else ""
            if n in self.unidentified and n not in self.at_bound:
                flag += f"  (not identifiable: {self.unidentified[n]})"
            lines.append(f"  {n:>10} = {self.parameters[n]: .6g} +/- {self.stderr[n]:.2g}{flag}")
        if self.active_constraints:
            lines.append("  active constraints: " + ", ".join(self.active_constraints))
        for why in self.reasons:
            lines.append(f"  {self.status_text}: {why}")
        return "\n".join(lines)
