"""A fit problem: parameters (lmfit.Parameters), a vectorised model, data, objective, constraints.

Every relation and MF stage is expressed as a :class:`FitProblem` and solved by
:func:`identify.fit.optimize.fit`. Nothing here loops over data points.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import lmfit
import numpy as np

from identify.fit.solve.metric import group_weights, thesis_error_by_group

NOISE_MODELS = ("weights", "relative", "sweep", "sweep-residual")
COVARIANCES = ("iid", "sweeps")
"""How the standard errors of a problem are computed (FitProblem.covariance)."""
MIN_CLUSTERS = 10
"""Fewest sweeps for the sweep-clustered covariance (and more than the free coefficients);
with fewer the covariance is the iid one."""
NOISE_FLOOR = 0.01
"""Smallest noise level of a point, as a fraction of the RMS of all measurements."""
RESIDUAL_FLOOR = 0.1
"""``noise="sweep-residual"``: smallest level of a sweep, as a fraction of the pooled RMS of
the residuals."""
PRIOR_POINTS = 10.0
"""``noise="sweep-residual"``: the pooled residual variance counts as this many points of
each sweep's own (a sweep of 1 point takes the pooled level, one of 130 nearly its own)."""
PENALTY = 1e6
"""The weighted residual of a point where the model is not finite (FitProblem.residuals; its
derivative is 0). Weighted residuals are in units of the noise level: no measured point comes
near it."""


def penalised(r: np.ndarray) -> bool:
    """Some residual of ``r`` is the PENALTY of a non-finite model value: the residual variance
    there is the penalty's, not the noise's, and no test on it (the engine's noise stops, the
    Gauss-Newton phase's convergence) may be read as closeness to an optimum."""
    return bool(np.any(np.abs(r) >= PENALTY))


ModelFn = Callable[[Mapping[str, float | np.ndarray]], np.ndarray]
"""model(values) -> predictions [unit of the data], one per data point; values maps every
parameter name (free and fixed) to a float (or, for MCMC, to an array of shape (walkers, 1))."""

JacobianFn = Callable[[Mapping[str, float], tuple[str, ...]], np.ndarray]
"""jacobian(values, names) -> d model / d names, shape (points, len(names)) [unit of the data
per unit of each parameter]: the exact derivatives of the model with respect to the named
parameters at ``values`` (every parameter name -> float). The fit asks for the free parameters
(columns in ``FitProblem.free`` order); discovery asks for candidate coefficients that are held
fixed as well, so the names are an argument rather than fixed when the problem is built."""


@dataclass(frozen=True)
class Constraint:
    """A general inequality constraint g(values) >= 0 (elementwise).

    Attributes
    ----------
    name : str
        Short name shown in results (``"CMz >= 0 for Fz in [500, 8000] N"``).
    fun : callable
        values -> array; every element must be >= 0.
    local : callable or None
        values -> a function equal to ``fun`` near ``values`` at a fraction of its cost (a
        minimum over a grid evaluated only on the grid points near the minimum at
        ``values``: identify.fit.mf.constraints), for the finite-difference Jacobian of the
        constrained polish; None: ``fun`` itself.
    batched : bool
        ``fun`` and the functions ``local`` returns also take values whose free parameters are
        arrays of shape (m, 1) (:meth:`FitProblem.values_batch`) and then return (m, ...),
        row i the same numbers as a call with row i alone: the polish's finite differences
        then evaluate all their steps in one call.
    """

    name: str
    fun: Callable[[Mapping[str, float]], np.ndarray]
    local: Callable[[Mapping[str, float]], Callable[[Mapping[str, float]], np.ndarray]] | None \
        = None
    batched: bool = False


@dataclass(frozen=True)
class FitProblem:
    """What to fit.

    Attributes
    ----------
    relation, form : str
        Names for results (``"CFy"``, ``"linear_load"``).
    parameters : lmfit.Parameters
        Initial values, bounds, and which vary; never modified by the fit.
    model : ModelFn
        Vectorised model of the data.
    measured : ndarray
        The data [unit of the characteristic].
    pressure_bar : ndarray
        Inflation pressure of each point [bar]: the groups of the thesis metric.
    objective : str
        ``"thesis"`` minimises the total thesis error (mean over pressures);
        ``"wls"`` minimises weighted least squares (weights below).
    sigma : ndarray or None
        Standard deviation of each point for ``"wls"`` [unit of the data]; None weights each
        pressure by 1/sqrt(sum A_meas^2) (the least-squares companion of the thesis metric).
    constraints : tuple of Constraint
    sweeps : ndarray or None
        Sweep id of each point (for AR(1) noise in MCMC and for diagnostics).
    unit : str
        Unit of the data, for reports.
    covariance : str
        How the standard errors are computed (identify.fit.solve.engine.covariance,
        docs/intervals.md):
        ``"iid"``: s^2 (J^T J)^-1, residuals independent with one variance (sigma known: s = 1);
        ``"sweeps"``: the delete-one-sweep jackknife over ``sweeps``, residuals correlated and
        of any variance within a sweep (AR(1) noise, drift, binned sweeps), independent
        between sweeps; the iid one when there are fewer than MIN_CLUSTERS sweeps or not more
        sweeps than free coefficients (:meth:`clusters`).
    jacobian : JacobianFn or None
        Exact derivatives of ``model`` (see :data:`JacobianFn`), or None for finite
        differences. When given, the least-squares solver uses it (``jac=``), the covariance is
        computed from it, the constrained polish gets the exact gradient of the objective, and
        discovery uses it for the candidates' columns. Its evaluations are not counted as model
        evaluations (FitResult.nfev).
    noise : str
        Noise model of the MCMC likelihood (identify.fit.mcmc.chains), i.e. how the standard
        deviation of a point scales with the one noise-level parameter sigma:
        ``"weights"``: sigma / w_i with the objective's weights (as the fit);
        ``"relative"``: sigma |A_meas,i| -- a characteristic measured to a relative accuracy,
        sigma is the noise level as a fraction (1 % noise -> 0.01); ``"sweep"``: sigma x the
        RMS of the measurements of the point's sweep -- a channel whose noise is a fraction of
        its level over a sweep (the simulator's definition of 1 % noise);
        ``"sweep-residual"``: sigma x each sweep's noise level as the least-squares fit left
        it, the RMS of the residuals of the point's sweep at the optimum, shrunk towards the
        pooled RMS by :data:`PRIOR_POINTS` -- a sensor's additive noise, which a sweep of
        small forces shares with a sweep of large ones (an Fy0 sweep at zero slip angle, Fy
        ~200 N, carries the same noise as a +-12 deg sweep of Fy ~3 kN: ``"sweep"`` would count
        its noise over ten times larger than the others', so the likelihood would misstate
        sigma and the chain would sample a posterior the data do not support).
        A homoscedastic likelihood on data whose noise grows with the value makes the
        credible intervals of the coefficients set by the largest values too narrow
        (tests/unit/test_fit_calibration.py checks the coverage of 90 % intervals under relative
        noise).
    """

    relation: str
    form: str
    parameters: lmfit.Parameters
    model: ModelFn
    measured: np.ndarray
    pressure_bar: np.ndarray
    objective: str = "thesis"
    sigma: np.ndarray | None = None
    constraints: tuple[Constraint, ...] = ()
    sweeps: np.ndarray | None = None
    unit: str = ""
    extra: Mapping[str, object] = field(default_factory=dict)
    noise: str = "weights"
    jacobian: JacobianFn | None = None
    covariance: str = "iid"

    def __post_init__(self) -> None:
        if self.covariance not in COVARIANCES:
            raise ValueError(f"covariance must be one of {COVARIANCES}, not "
                             f"{self.covariance!r}")
        if self.objective not in ("thesis", "wls"):
            raise ValueError(f"objective must be 'thesis' or 'wls', not {self.objective!r}")
        if self.noise not in NOISE_MODELS:
            raise ValueError(f"noise must be one of {NOISE_MODELS}, not {self.noise!r}")
        object.__setattr__(self, "measured", np.asarray(self.measured, dtype=float))
        object.__setattr__(self, "pressure_bar", np.asarray(self.pressure_bar, dtype=float))
        # group index of every point and sum of squared data per pressure, for a fast
        # thesis objective (it is evaluated thousands of times per fit)
        levels, index = np.unique(self.pressure_bar, return_inverse=True)
        object.__setattr__(self, "_group_index", index)
        object.__setattr__(self, "_group_den", np.bincount(index, self.measured ** 2,
                                                           minlength=levels.size))
        # the objective's weights, once: every residual evaluation multiplies by them (a
        # pressure measured as all 0 gets an infinite weight, without a warning for problems
        # whose weights are never used)
        with np.errstate(divide="ignore"):
            weights = np.array(1.0 / np.asarray(self.sigma, dtype=float)
                               if self.sigma is not None
                               else group_weights(self.measured, self.pressure_bar),
                               dtype=float)
        weights.flags.writeable = False
        object.__setattr__(self, "_weights", weights)

    # ----- parameter vectors -------------------------------------------------------------
    def _read(self) -> tuple[tuple[str, ...], dict[str, float]]:
        """(free names, every value) as the parameters stand at the problem's first
        evaluation, read once: the objective asks for them at every evaluation, and reading
        a few hundred lmfit parameters each time cost a large part of a constrained polish.
        The parameters are never modified once the problem is evaluated (a change makes a
        new problem: :func:`with_free`, :func:`with_fixed`)."""
        read = self.__dict__.get("_read_once")
        if read is None:
            read = (tuple(n for n, p in self.parameters.items() if p.vary),
                    {n: float(p.value) for n, p in self.parameters.items()})
            object.__setattr__(self, "_read_once", read)
        return read

    @property
    def free(self) -> tuple[str, ...]:
        """Names of the varying parameters, in declaration order."""
        return self._read()[0]

    def values(self, x: np.ndarray | None = None) -> dict[str, float]:
        """All parameter values, with the free ones taken from ``x`` when given."""
        free, every = self._read()
        vals = dict(every)
        if x is not None:
            vals.update(zip(free, (float(v) for v in x)))
        return vals

    def values_batch(self, X: np.ndarray) -> dict[str, float | np.ndarray]:
        """All parameter values for the rows of ``X`` (m, free) at once: each free one an
        array of shape (m, 1), the held ones floats (the broadcasting form of the vectorised
        models and constraints, :data:`ModelFn`)."""
        free, every = self._read()
        X = np.asarray(X, dtype=float)
        vals: dict[str, float | np.ndarray] = dict(every)
        vals.update((n, X[:, j:j + 1]) for j, n in enumerate(free))
        return vals

    def x0(self) -> np.ndarray:
        return np.array([self.parameters[n].value for n in self.free], dtype=float)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array([self.parameters[n].min for n in self.free], dtype=float)
        hi = np.array([self.parameters[n].max for n in self.free], dtype=float)
        return lo, hi

    def clusters(self) -> list[np.ndarray] | None:
        """Index arrays of the sweeps, the clusters of the covariance; None for the iid
        covariance (``covariance="iid"``, no sweeps, nothing free, fewer than MIN_CLUSTERS
        sweeps or not more sweeps than free coefficients)."""
        if self.covariance != "sweeps" or self.sweeps is None or not self.free:
            return None
        _, index = np.unique(np.asarray(self.sweeps), return_inverse=True)
        index = index.ravel()
        C = int(index.max(initial=-1)) + 1
        if C < MIN_CLUSTERS or C <= len(self.free):
            return None
        order = np.argsort(index, kind="stable")
        return np.split(order, np.cumsum(np.bincount(index, minlength=C))[:-1])

    def covariance_used(self, jackknife_defined: bool = True) -> tuple[str, int]:
        """(the covariance the standard errors come from, its number of clusters):
        ``("sweep-jackknife", C)``, ``("iid", 0)`` or ``("iid-known-sigma", 0)``
        (FitResult.covariance, .clusters). ``jackknife_defined``: False when one sweep alone
        determines a combination of the coefficients (identify.fit.solve.engine.jackknife_defined):
        iid then."""
        clusters = self.clusters() if jackknife_defined else None
        if clusters is not None:
            return "sweep-jackknife", len(clusters)
        return ("iid-known-sigma" if self.sigma is not None else "iid"), 0

    # ----- objective -----------------------------------------------------------------------
    def predict(self, x: np.ndarray | None = None) -> np.ndarray:
        # trial points outside a model's domain give NaN, which the objective penalises
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return np.asarray(self.model(self.values(x)), dtype=float)

    def weights(self) -> np.ndarray:
        """The objective's weight of each point (read-only): 1/sigma, or per pressure
        1/sqrt(sum A_meas^2) (identify.fit.solve.metric.group_weights)."""
        return self._weights

    def noise_weights(self, x: np.ndarray | None = None) -> np.ndarray:
        """1 / (standard deviation of each point at sigma = 1) under the ``noise`` model.

        ``x``: the least-squares optimum (free parameters), which ``"sweep-residual"`` needs.
        Levels are floored at NOISE_FLOOR x the RMS of all measurements, so that a point (or
        sweep) measured as ~0 does not get an unbounded weight ("sweep-residual": at
        RESIDUAL_FLOOR x the pooled RMS of the residuals).
        """
        if self.noise == "weights":
            return self.weights()
        meas = np.abs(self.measured)
        floor = NOISE_FLOOR * max(float(np.sqrt(np.mean(meas ** 2))), np.finfo(float).tiny)
        if self.noise == "relative":
            return 1.0 / np.maximum(meas, floor)
        groups = self.sweeps if self.sweeps is not None else self.pressure_bar
        _, index = np.unique(np.asarray(groups), return_inverse=True)
        count = np.bincount(index)
        if self.noise == "sweep":
            level = np.sqrt(np.bincount(index, meas ** 2) / count)
        else:
            if x is None:
                raise ValueError('noise="sweep-residual" needs the optimum x')
            r = self.predict(x) - self.measured
            # a non-finite residual (a NaN sample, a model off its domain) tells nothing of
            # the noise: it counts in no level, neither its sweep's nor the pooled one
            ok = np.isfinite(r)
            r = np.where(ok, r, 0.0)
            pooled = float(np.sum(r ** 2)) / max(int(ok.sum()), 1)
            level = np.sqrt((np.bincount(index, r ** 2) + PRIOR_POINTS * pooled)
                            / (np.bincount(index, ok, minlength=count.size) + PRIOR_POINTS))
            # the floor follows the noise, not the data's size (noise may be well below 1 %
            # of the values); only an exact fit falls back to the data's
            floor = RESIDUAL_FLOOR * np.sqrt(pooled) if pooled > 0 else floor
        return 1.0 / np.maximum(level[index], floor)

    def residuals(self, x: np.ndarray | None = None) -> np.ndarray:
        """Weighted residuals w*(model - measured); non-finite model values are penalised."""
        r = (self.predict(x) - self.measured) * self.weights()
        return r if np.isfinite(r).all() else np.where(np.isfinite(r), r, PENALTY)

    def model_jacobian(self, x: np.ndarray | None = None,
                       names: tuple[str, ...] | None = None) -> np.ndarray | None:
        """Exact d model / d ``names`` (default: the free parameters) at ``x``, shape
        (points, len(names)); None when the problem has no Jacobian."""
        if self.jacobian is None:
            return None
        names = self.free if names is None else tuple(names)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            J = np.asarray(self.jacobian(self.values(x), names), dtype=float)
        J = J.reshape(self.measured.size, len(names))
        # a copy only where a derivative is not finite (the solvers take one per iteration)
        return J if np.isfinite(J).all() else np.where(np.isfinite(J), J, 0.0)

    def residual_jacobian(self, x: np.ndarray | None = None,
                          names: tuple[str, ...] | None = None) -> np.ndarray | None:
        """Exact d(weighted residuals) / d ``names`` (default: the free parameters), or None
        without a Jacobian. Non-finite derivatives are 0 (as the residuals' penalty for a
        non-finite model value is a constant)."""
        J = self.model_jacobian(x, names)
        return None if J is None else J * self.weights()[:, None]

    def objective_gradient(self, x: np.ndarray) -> np.ndarray | None:
        """Exact gradient of :meth:`objective_value` with respect to the free parameters, or
        None without a Jacobian. Thesis objective: mean over pressures of
        100 sqrt(num_g / den_g), d/dx = mean of 100 / (2 sqrt(num_g den_g)) d num_g / dx with
        d num_g / dx = 2 sum_(i in g) (pred_i - meas_i) d pred_i / dx (a pressure fitted
        exactly, num_g = 0, contributes 0)."""
        J = self.model_jacobian(x)
        if J is None:
            return None
        if self.objective == "wls":
            return J.T @ (self.residuals(x) * self.weights())
        e = self.predict(x) - self.measured
        if not np.all(np.isfinite(e)):
            return np.zeros(J.shape[1])
        num = np.bincount(self._group_index, e ** 2, minlength=self._group_den.size)
        dnum = np.stack([np.bincount(self._group_index, 2.0 * e * J[:, j],
                                     minlength=self._group_den.size)
                         for j in range(J.shape[1])], axis=1).reshape(num.size, -1)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = np.where(num > 0, 100.0 / (2.0 * np.sqrt(num * self._group_den)), 0.0)
        return (f[:, None] * dnum).mean(axis=0)

    def thesis_by_pressure(self, x: np.ndarray | None = None) -> dict[float, float]:
        return thesis_error_by_group(self.predict(x), self.measured, self.pressure_bar)

    def objective_value(self, x: np.ndarray) -> float:
        """The scalar the optimiser minimises."""
        if self.objective == "wls":
            r = self.residuals(x)
            return float(0.5 * r @ r)
        pred = self.predict(x)
        if not np.all(np.isfinite(pred)):
            return 1e12
        num = np.bincount(self._group_index, (pred - self.measured) ** 2,
                          minlength=self._group_den.size)
        with np.errstate(divide="ignore", invalid="ignore"):
            eps = 100.0 * np.sqrt(num / self._group_den)
        return float(np.mean(eps))

    def constraint_values(self, x: np.ndarray) -> np.ndarray:
        """All constraint values concatenated (each must be >= 0)."""
        if not self.constraints:
            return np.zeros(0)
        vals = self.values(x)
        return np.concatenate([np.atleast_1d(np.asarray(c.fun(vals), dtype=float))
                               for c in self.constraints])

    def local_constraints(self, x: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """A function x' -> :meth:`constraint_values` (x') for x' near ``x``: each constraint's
        ``local`` one at ``x`` where it has one (Constraint.local), its ``fun`` otherwise."""
        vals = self.values(x)
        funs = [c.fun if c.local is None else c.local(vals) for c in self.constraints]

        def local(x1: np.ndarray) -> np.ndarray:
            if not funs:
                return np.zeros(0)
            v = self.values(x1)
            return np.concatenate([np.atleast_1d(np.asarray(f(v), dtype=float))
                                   for f in funs])

        if funs and all(c.batched for c in self.constraints):
            def batch(X: np.ndarray) -> np.ndarray:
                """``local`` at each row of X (m, free) in one call: (m, constraints)."""
                m = np.asarray(X).shape[0]
                v = self.values_batch(X)
                parts = []
                for f in funs:
                    g = np.asarray(f(v), dtype=float)
                    # a condition that reads no free parameter is the same in every row
                    parts.append(g.reshape(m, -1) if g.ndim == 2 else
                                 np.broadcast_to(np.atleast_1d(g), (m, g.size)))
                return np.concatenate(parts, axis=1)
            local.batch = batch  # type: ignore[attr-defined]
        return local


def with_free(problem: FitProblem, values: dict[str, float],
              bounds: dict[str, tuple[float, float]]) -> FitProblem:
    """A copy with the named parameters freed at ``values`` within ``bounds``."""
    P = problem.parameters.copy()
    for k, v in values.items():
        lo, hi = bounds[k]
        P[k].set(value=float(np.clip(v, lo, hi)), vary=True, min=lo, max=hi)
    return replace(problem, parameters=P)


def with_fixed(problem: FitProblem, names: list[str], x: np.ndarray) -> FitProblem:
    """A copy with the named free parameters held at their values in ``x`` (``problem.free``
    order)."""
    P = problem.parameters.copy()
    for k in names:
        P[k].set(value=float(x[problem.free.index(k)]), vary=False)
    return replace(problem, parameters=P)
