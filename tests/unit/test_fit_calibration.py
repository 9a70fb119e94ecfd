"""Calibration of the MCMC credible intervals (issue 5, acceptance 3), behind the trials marker.

For every relation (and MF stage, tests/unit/test_fit_calibration_mf.py): 40 seeded data sets with
1 % noise from known coefficients; the 90 % credible interval must contain the true coefficient
in >= 85 % of (trials x coefficients), and every chain must have met the 50-tau rule. Run with
``make trials`` (or ``pytest -m trials tests/unit/test_fit_calibration.py -s``); ``-s`` prints one
summary line per case (hits, rate, chains converged, median steps and tau, wall time).

Noise: each measured characteristic is multiplied by (1 + 0.01 N(0, 1)).
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from identify.fit.mcmc.chains import run_mcmc
from identify.fit.optimize import fit
from identify.fit.relations import problems as R
from identify.fit.solve.problem import FitProblem
from identify.io.tir import read_tir
from identify.model import relations as rel
from tests.unit.test_fit_relations import CTX, FZ0, LOADS, P0_BAR, PRESSURES, TIR, _cases, _grid

N_TRIALS = 40
NOISE = 0.01
LEVEL = 0.90
MIN_RATE = 0.85
MF_TIR = "identify/simulate/data/tyre_225_50R17.tir"


@dataclass(frozen=True)
class Case:
    """One calibration case: ``trial(rng)`` -> (problem from noisy data, true coefficients)."""

    name: str
    trial: Callable[[np.random.Generator], tuple[FitProblem, dict[str, float]]]


def _noisy(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    out = frame.copy()
    out["value"] = frame["value"] * (1 + NOISE * rng.standard_normal(len(frame)))
    return out


@dataclass
class Tally:
    """Running count over trials of the LEVEL credible intervals that hold the true value."""

    hits: int = 0
    total: int = 0
    converged: int = 0
    trials: int = 0
    steps: list = field(default_factory=list)
    taus: list = field(default_factory=list)
    misses: dict = field(default_factory=dict)

    def add(self, mcmc, names, truth: dict[str, float]) -> None:
        """Count one trial's chain: its convergence and, per name in ``truth``, a hit."""
        self.trials += 1
        self.converged += mcmc.converged
        self.steps.append(mcmc.n_steps)
        self.taus.append(max(mcmc.tau.values()))
        for name in names:
            if name not in truth:
                continue
            lo, hi = mcmc.interval(name, LEVEL)
            inside = lo <= truth[name] <= hi
            self.hits += inside
            self.total += 1
            if not inside:
                self.misses[name] = self.misses.get(name, 0) + 1

    def summary(self, case: str, seconds: float) -> dict:
        return dict(case=case, hits=self.hits, total=self.total, rate=self.hits / self.total,
                    converged=self.converged, trials=self.trials,
                    median_steps=float(np.median(self.steps)),
                    median_tau=float(np.median(self.taus)), seconds=seconds,
                    misses=self.misses)

    def line(self) -> str:
        return (f"{self.hits}/{self.total} = {self.hits / self.total:.1%} of {LEVEL:.0%} "
                f"intervals hold the truth; {self.converged}/{self.trials} chains past 50 tau "
                f"(median {np.median(self.steps):.0f} steps, tau {np.median(self.taus):.0f})")


def calibrate(case: Case, n_trials: int = N_TRIALS, seed0: int = 1000) -> dict:
    """Run the trials of one case; return the counts (and print them)."""
    t0 = time.perf_counter()
    tally = Tally()
    for seed in range(n_trials):
        problem, truth = case.trial(np.random.default_rng(seed0 + seed))
        result = run_mcmc(problem, fit(problem, seed=seed), seed=seed)
        tally.add(result.mcmc, problem.free, truth)
    seconds = time.perf_counter() - t0
    print(f"\n{case.name}: {tally.line()}; {seconds:.0f} s; misses by coefficient "
          f"{tally.misses}")
    return tally.summary(case.name, seconds)


# ----- cases -----------------------------------------------------------------------------------

def _grid_cases():
    """The recovery cases of tests/unit/test_fit_relations.py (CFz, CFx, CFy, CMz)."""
    for relation, form, data, truth, builder in _cases():
        def trial(rng, relation=relation, form=form, data=data, truth=truth, builder=builder):
            problem = builder(_noisy(data, rng), CTX, form=form)
            if relation == "CMz" and form == "T2":
                problem.parameters["YAW_STIFFNESS"].set(value=5000.0)
            return problem, truth
        yield Case(f"{relation}-{form}", trial)


RR_TRUTH = {"new": dict(QSY1=0.0085, QSY3=0.0006, QSY4=3e-5, QSY7=0.87, QSY8=-0.4),
            "old": dict(QSY1=0.0085, QSY3=0.0006, QSY4=3e-5, QSY7=1.0, QSY8=0.0)}


def _mf_tir() -> dict[str, float]:
    return read_tir(MF_TIR).params()


def _rolling_resistance_case(form: str) -> Case:
    """Fx,RR at 5 pressures x 3 loads x 3 speeds, from known QSY coefficients."""
    tir = _mf_tir()
    truth = RR_TRUTH[form]
    ctx = R.Context(tir["FNOMIN"], tir["NOMPRES"] / 1e5, tir)
    pi, fz, vx = (a.ravel() for a in np.meshgrid(PRESSURES, LOADS, [5.0, 15.0, 25.0],
                                                 indexing="ij"))
    frame = pd.DataFrame({"quantity": "FxRR", "pi_bar": pi, "p_Pa": pi * 1e5, "Fz_N": fz,
                          "Vx_mps": vx, "value": 0.0, "unit": "N"})
    frame["value"] = R.rolling_resistance(frame, R.Context(ctx.fz0, ctx.p0_bar, {**tir, **truth}),
                                          form=form).predict()

    def trial(rng):
        problem = R.rolling_resistance(_noisy(frame, rng), ctx, form=form)
        return problem, {k: v for k, v in truth.items() if k in problem.free}
    return Case(f"RR-{form}", trial)


CAMBER_TRUTH = {"Fy_gamma": ("PPY5", -0.3), "Mx_gamma": ("PPMX1", -0.3),
                "Mz_gamma": ("PPZ2", -0.4)}


def _camber_case(quantity: str) -> Case:
    """Camber thrust or torque at 5 pressures x 3 loads x 4 camber angles through the MF; the
    .tir's own value of the coefficient is the start."""
    tir = _mf_tir()
    key, value = CAMBER_TRUTH[quantity]
    ctx = R.Context(tir["FNOMIN"], tir["NOMPRES"] / 1e5, tir)
    pi, fz, gd = (a.ravel() for a in np.meshgrid(PRESSURES, LOADS, [-10.0, -5.0, 5.0, 10.0],
                                                 indexing="ij"))
    frame = pd.DataFrame({"quantity": quantity, "pi_bar": pi, "p_Pa": pi * 1e5, "Fz_N": fz,
                          "gamma_deg": gd, "value": 0.0, "unit": "N"})
    hidden = R.Context(ctx.fz0, ctx.p0_bar, {**tir, key: value})
    frame["value"] = R.camber(frame, hidden, quantity).predict()

    def trial(rng):
        return R.camber(_noisy(frame, rng), ctx, quantity), {key: value}
    return Case(f"camber-{quantity}", trial)


# the simulator's ring: c0 [N/m, N m/rad], f [-], belt mass and inertias
RING = rel.SidewallRing(c0=(1.97e6, 5.43e5, 1.97e6, 1.354e5, 3.75e4, 3.75e4),
                        f=(0.65, 0.74, 0.65, 0.69, 0.49, 0.49), m_b=7.8, i_bx=0.38, i_by=0.70)


def _sidewall_case(mode: str, form: str) -> Case:
    """Free-hanging eigenfrequency of one ring mode at 5 pressures (one per pressure, as the
    simulator measures them): ``scaling`` data from the ring's f_<mode>, ``rotta`` data from
    the Rotta form with the ring's f0."""
    f0 = float(RING.frequency(mode, 0.0))
    M = mode.upper()
    if form == "scaling":
        values = RING.frequency(mode, rel.dpi(PRESSURES, P0_BAR))
        truth = {f"F0_{M}": f0, f"F_{M}": RING.f[rel.RING_MODES.index(mode)]}
    else:
        ring = rel.rotta_ring(PRESSURES * 1e5, 0.300, 1.6e6, 0.010, 0.121,
                              np.deg2rad(62.3))[mode]
        ring0 = rel.rotta_ring(P0_BAR * 1e5, 0.300, 1.6e6, 0.010, 0.121,
                               np.deg2rad(62.3))[mode]
        values = f0 * np.sqrt(ring / ring0)
        truth = {f"F0_{M}": f0}
    frame = pd.DataFrame({"quantity": "f_nat", "pi_bar": PRESSURES, "p_Pa": PRESSURES * 1e5,
                          "Fz_N": 0.0, "mode": mode, "value": values, "unit": "Hz"})

    def trial(rng):
        return R.sidewall(_noisy(frame, rng), CTX, mode, form=form), truth
    return Case(f"sidewall-{form}-{mode}", trial)


RELAX_LOADS = np.array([2000.0, 3500.0, 5000.0, 6500.0, 8000.0])
RELAX_TRUTH = dict(LATERAL_STIFFNESS=1.4e5, PCFY1=0.1, PCFY2=-0.25, PCFY3=0.46,
                   PKY1=-29.9, PKY2=2.0, PPY1=0.45, PPY2=0.78)


def _relaxation_case(cofit: bool) -> Case:
    """sigma_y = |Kya|/CFy at 5 pressures x 5 loads. ``cofit``: the .tir's Kya is not
    identified, PKY1, PKY2, PPY1, PPY2 are fitted with the CFy shape (LATERAL_STIFFNESS held
    at the locked-hub median, here the truth); else Kya is the .tir's (the truth) and
    LATERAL_STIFFNESS, PCFY1..3 are fitted."""
    t = RELAX_TRUTH

    def sigma(fz, dp):
        k = rel.kya(fz, dp, t["PKY1"], t["PKY2"], t["PPY1"], t["PPY2"], FZ0)
        return np.abs(k) / rel.load_pressure_stiffness(fz, dp, t["LATERAL_STIFFNESS"],
                                                       t["PCFY1"], t["PCFY2"], t["PCFY3"], FZ0)
    data = _grid("sigma_y", sigma, loads=RELAX_LOADS)
    if cofit:
        # the .tir's Kya is a poor start (not identified), its lateral stiffness the truth
        tir = dict(TIR, LATERAL_STIFFNESS=t["LATERAL_STIFFNESS"], PKY1=-22.0, PKY2=1.5,
                   PPY1=0.2, PPY2=0.5)
        free = ("PCFY1", "PCFY2", "PCFY3", "PKY1", "PKY2", "PPY1", "PPY2")
    else:
        tir = dict(TIR, PKY1=t["PKY1"], PKY2=t["PKY2"], PPY1=t["PPY1"], PPY2=t["PPY2"])
        free = ("LATERAL_STIFFNESS", "PCFY1", "PCFY2", "PCFY3")
    ctx = R.Context(FZ0, P0_BAR, tir, kya_from_tir=not cofit)
    truth = {k: t[k] for k in free}

    def trial(rng):
        problem = R.cfy(_noisy(data, rng), ctx, "relaxation")
        assert set(problem.free) == set(free)
        return problem, truth
    return Case("CFy-relaxation" + ("-cofit-kya" if cofit else ""), trial)


def _new_cases():
    yield _rolling_resistance_case("old")
    yield _rolling_resistance_case("new")
    for quantity in CAMBER_TRUTH:
        yield _camber_case(quantity)
    for form in ("scaling", "rotta"):
        for mode in rel.RING_MODES:
            yield _sidewall_case(mode, form)
    yield _relaxation_case(cofit=False)
    yield _relaxation_case(cofit=True)


CASES = list(_grid_cases()) + list(_new_cases())
