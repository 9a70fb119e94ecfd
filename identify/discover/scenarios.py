"""Synthetic discovery problems with one effect hidden (for trials and tests).

Each scenario generates data directly from the model on its test matrix (no files): the
bundled 225/50 R17 tyre with its base-model coefficients randomised (+-10 %), every library
coefficient of the problem at its neutral value except the hidden one, measurement noise of a
given fraction of each sweep's RMS (of each file's, kind x pressure, for the short
rolling-resistance sweeps), independent or AR(1) along each sweep. The base problem starts from
the unrandomised tyre.

Scenarios (problem name: test matrix):

- ``MF/Fy``: trailer cornering (alpha +-12 deg) and camber sweeps (gamma +-8 deg at alpha = 0;
  alpha +-10 deg at gamma = +-4 deg), 3 pressures x 4 loads (2 to 8 kN);
- ``MF/Fx``: trailer braking/driving sweeps (kappa +-0.3), 3 pressures x 4 loads;
- ``MF/Mx``: overturning moment of the cornering and camber sweeps;
- ``RR``: trailer rolling-resistance sweeps (6 speeds, 20 samples), 3 pressures x 4 loads;
- ``CFy``: Flatplank locked-hub lateral runs, force vs plank displacement (+-5 mm),
  5 pressures x 3 loads.

A confounded design (:func:`make_confounded`): a rolling-resistance table of 20 points, five
load/pressure pairs (each load at one pressure only; the pressure falls with load overall,
correlation of log load and log pressure -0.74) at four speeds each, no sweeps, with both the
load exponent QSY7 and the pressure exponent QSY8 hidden. Each alone absorbs part of the
other's effect, so a single addition can fit better yet predict a left-out pair worse (as
leave-one-pressure-out folds show); only the pair generalises.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import lru_cache

import lmfit
import numpy as np
import pandas as pd

from identify.discover.stage_problems import DISCOVERY_STAGES, stage_problem, sweep_shapes
from identify.fit.relations.problems import Context, rolling_resistance
from identify.fit.solve.problem import FitProblem
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.relations import load_pressure_stiffness
from identify.simulate import default_tir_path

__all__ = ["EFFECTS", "SCENARIOS", "Matrix", "make_problem", "base_tir", "make_confounded",
           "make_session", "CONFOUNDED_PAIRS", "CONFOUNDED_SPEEDS"]

#: hidden effect -> (scenario, smallest and largest |deviation from neutral|)
EFFECTS: dict[str, tuple[str, float, float]] = {
    "PPY5": ("MF/Fy", 0.10, 0.30), "PPY1": ("MF/Fy", 0.20, 0.60),
    "PPY3": ("MF/Fy", 0.05, 0.15), "PPX1": ("MF/Fx", 0.20, 0.60),
    "PPX3": ("MF/Fx", 0.05, 0.15), "PPMX1": ("MF/Mx", 0.05, 0.20),
    "QSY8": ("RR", 0.20, 0.60), "QSY7": ("RR", 0.08, 0.20),
    "PCFY2": ("CFy", 0.10, 0.40),
}
SCENARIOS = ("MF/Fy", "MF/Fx", "MF/Mx", "RR", "CFy")
_NEUTRAL_KEYS = ("PPX1", "PPX2", "PPX3", "PPX4", "PPY1", "PPY2", "PPY3", "PPY4", "PPY5",
                 "PPZ1", "PPZ2", "PPMX1", "QSY8", "PFZ1")


@dataclass(frozen=True)
class Matrix:
    """A test matrix: pressures [bar], loads [N], samples per sweep (scaled by ``density``)."""

    pressures_bar: tuple[float, ...] = (1.9, 2.5, 3.0)
    loads: tuple[float, ...] = (2000.0, 4000.0, 6000.0, 8000.0)
    density: float = 1.0

    def n(self, samples: int) -> int:
        return max(9, int(round(samples * self.density)) | 1)


@lru_cache(maxsize=1)
def _default_tir() -> tuple:

    params = read_tir(default_tir_path()).params()
    return tuple((k, float(v)) for k, v in params.items() if isinstance(v, (int, float)))


def base_tir() -> dict[str, float]:
    """The bundled tyre with every library pressure coefficient neutral (QSY7 = 1) and the
    cornering stiffness peaking at 1.7 Fz0 (PKY2; the bundled 3.0 makes PPY1 and PPY2 an
    ambiguity group at trailer loads, |cos| = 0.99)."""
    t = dict(_default_tir())
    t["PKY2"] = 1.7
    t.update({k: 0.0 for k in _NEUTRAL_KEYS})
    t["QSY7"] = 1.0
    return t


def _triangle(a: float, n: int) -> np.ndarray:
    s = np.linspace(0.0, 4.0, n)
    return a * np.where(s <= 1, s, np.where(s <= 3, 2 - s, s - 4))


def _trailer(kind: str, m: Matrix) -> pd.DataFrame:
    """Operating points of one trailer test at every pressure and load, sweeps labelled."""
    sweeps = []
    for p in m.pressures_bar:
        for fz in m.loads:
            if kind == "braking_driving":
                parts = [("braking_driving", {"kappa": _triangle(0.3, m.n(193))})]
            elif kind == "lateral":
                a = np.deg2rad
                parts = [("cornering", {"alpha": _triangle(a(12.0), m.n(193))}),
                         ("camber", {"gamma": _triangle(a(8.0), m.n(129))})]
                parts += [("camber", {"alpha": _triangle(a(10.0), m.n(193)),
                                      "gamma": np.full(m.n(193), a(g))}) for g in (-4.0, 4.0)]
            else:
                parts = [("rolling_resistance", {"Vx": np.full(m.n(20), v)})
                         for v in (5.0, 10.0, 15.0, 20.0, 25.0, 30.0)]
            for k, cols in parts:
                n = len(next(iter(cols.values())))
                d = {"kappa": 0.0, "alpha": 0.0, "gamma": 0.0, "Vx": 16.7, **cols}
                sweeps.append(pd.DataFrame({c: np.broadcast_to(d[c], n) for c in
                                            ("kappa", "alpha", "gamma", "Vx")}
                                           | {"Fz": fz, "p": p * 1e5, "kind": k,
                                              "run": f"{k}_p{round(p * 100)}"}))
    df = pd.concat(sweeps, ignore_index=True)
    df["sweep"] = np.repeat(np.arange(len(sweeps)), [len(s) for s in sweeps])
    df["shape"] = df["sweep"].map(sweep_shapes(df))
    return df


def _noise(rng, clean: np.ndarray, sweep: np.ndarray, group: np.ndarray, level: float,
           rho: float) -> np.ndarray:
    """level * RMS(group) std noise, AR(1) with lag-one correlation rho along each sweep."""
    e = np.empty_like(clean)
    for s in np.unique(sweep):
        idx = np.flatnonzero(sweep == s)
        z = rng.standard_normal(idx.size)
        x = np.empty(idx.size)
        x[0] = z[0]
        for t in range(1, idx.size):
            x[t] = rho * x[t - 1] + np.sqrt(1 - rho * rho) * z[t]
        e[idx] = x
    for g in np.unique(group):
        sel = group == g
        e[sel] *= level * np.sqrt(np.mean(clean[sel] ** 2))
    return clean + e


def _randomised(rng, t: dict, keys) -> dict:
    out = dict(t)
    for k in keys:
        out[k] = t[k] * (1.0 + rng.uniform(-0.1, 0.1))
    return out


def _named(problem: FitProblem, name: str, **extra) -> FitProblem:
    return dataclasses.replace(problem, extra={**problem.extra, "name": name, **extra})


def make_problem(scenario: str, rng: np.random.Generator, hidden: str | None = None,
                 value: float | None = None, *, noise: float = 0.01, rho: float = 0.0,
                 matrix: Matrix = Matrix()) -> tuple[FitProblem, dict]:
    """One synthetic base problem with ``hidden`` (a library name of the scenario) present in
    the data at ``value`` (random size and sign from :data:`EFFECTS` when None).

    Returns
    -------
    problem : FitProblem        base model (candidates at neutral) with the noisy data
    truth : dict                {"hidden", "value", "params"}: what generated the data
    """
    start = base_tir()
    if hidden is not None and value is None:
        _, lo, hi = EFFECTS[hidden]
        neutral = 1.0 if hidden == "QSY7" else 0.0
        value = neutral + rng.choice((-1.0, 1.0)) * rng.uniform(lo, hi)
    if scenario == "CFy":
        return _locked_hub(rng, start, hidden, value, noise, rho, matrix)
    stage = scenario.split("/")[-1] if scenario.startswith("MF/") else None
    free = DISCOVERY_STAGES[stage].free if stage else ("QSY1", "QSY3", "QSY4")
    truth = _randomised(rng, start, free)
    if hidden is not None:
        truth[hidden] = value
    kind = {"Fx": "braking_driving", "Fy": "lateral", "Mx": "lateral"}.get(stage, "rr")
    m = matrix if stage else dataclasses.replace(matrix, density=max(matrix.density, 1.0))
    frame = _trailer(kind, m)
    out = {"Fx": "Fx", "Fy": "Fy", "Mx": "Mx"}.get(stage, "My")
    clean = evaluate(truth, frame["Fz"].to_numpy(), frame["kappa"].to_numpy(),
                     frame["alpha"].to_numpy(), frame["gamma"].to_numpy(),
                     frame["Vx"].to_numpy(), p=frame["p"].to_numpy(), mode=111)[out]
    group = frame["sweep" if stage else "run"].to_numpy()
    frame[out] = _noise(rng, clean, frame["sweep"].to_numpy(), group, noise, rho)
    if stage:
        problem = stage_problem(stage, frame, start)
    else:
        chars = pd.DataFrame({"quantity": "FxRR", "pi_bar": frame["p"] / 1e5,
                              "p_Pa": frame["p"], "Fz_N": frame["Fz"], "Vx_mps": frame["Vx"],
                              "value": frame["My"] / start["UNLOADED_RADIUS"]})
        ctx = Context(fz0=start["FNOMIN"], p0_bar=start["NOMPRES"] / 1e5, tir=start)
        problem = dataclasses.replace(rolling_resistance(chars, ctx, form="old"),
                                      sweeps=frame["sweep"].to_numpy())
        problem = _named(problem, "RR", noise_group=frame["run"].to_numpy())
    return _named(problem, scenario), {"hidden": hidden, "value": value, "params": truth}


def _locked_hub(rng, start, hidden, value, noise, rho, m: Matrix) -> tuple[FitProblem, dict]:
    """Locked-hub lateral runs: Fy = CFy(Fz, p) * y on a +-5 mm triangle per run."""
    fz0, p0 = start["FNOMIN"], start["NOMPRES"]
    nominal = {"LATERAL_STIFFNESS": 139348.0, "PCFY1": 0.104703}
    truth = {k: v * (1.0 + rng.uniform(-0.1, 0.1)) for k, v in nominal.items()}
    truth.update({"PCFY2": 0.0, "PCFY3": 0.0})
    if hidden is not None:
        truth[hidden] = value
    pres = (1.9, 2.2, 2.5, 2.7, 3.0)
    n = m.n(150)
    y = np.tile(_triangle(0.005, n), len(pres) * len(m.loads))
    fz = np.repeat(np.tile(m.loads, len(pres)), n)
    pb = np.repeat(np.repeat(pres, len(m.loads)), n)
    sweep = np.repeat(np.arange(len(pres) * len(m.loads)), n)
    dp = (pb * 1e5 - p0) / p0

    def stiffness(v):
        return load_pressure_stiffness(fz, dp, v["LATERAL_STIFFNESS"], v["PCFY1"], v["PCFY2"],
                                       v["PCFY3"], fz0)
    meas = _noise(rng, stiffness(truth) * y, sweep, sweep, noise, rho)
    P = lmfit.Parameters()
    P.add("LATERAL_STIFFNESS", value=nominal["LATERAL_STIFFNESS"], min=0.0, max=1e7)
    P.add("PCFY1", value=nominal["PCFY1"], min=-1.0, max=1.0)
    P.add("PCFY2", value=0.0, vary=False)
    P.add("PCFY3", value=0.0, vary=False)
    problem = FitProblem("CFy", "locked_hub", P, lambda v: stiffness(v) * y, meas, pb,
                         objective="wls", sweeps=sweep, unit="N",
                         extra={"name": "CFy", "quantity": "Fy", "Fz_N": fz,
                                "noise_group": sweep})
    return problem, {"hidden": hidden, "value": value, "params": truth}


#: (Fz / FNOMIN, pressure [bar]) of the confounded rolling-resistance table
CONFOUNDED_PAIRS = ((0.5, 2.6), (0.7, 2.9), (0.9, 2.2), (1.1, 2.4), (1.3, 2.0))
#: its four speeds [m/s]
CONFOUNDED_SPEEDS = (8.33, 13.89, 22.22, 30.56)


def make_confounded(rng: np.random.Generator, hidden: bool = True, *, noise: float = 0.01,
                    values: tuple[float, float] | None = None) -> tuple[FitProblem, dict]:
    """The confounded rolling-resistance table (module doc) as the base problem ``RR`` (old
    form: QSY7 = 1, QSY8 = 0), with QSY7 and QSY8 in the data when ``hidden``.

    QSY7 = 1 - U(0.08, 0.20) and QSY8 = -U(0.2, 0.6) (the physical signs: resistance grows
    less than in proportion to load and falls with pressure), unless ``values`` gives them;
    QSY1, QSY3, QSY4 randomised by +-10 %; independent noise of ``noise`` x the RMS of each
    load/pressure pair's four values (as the other scenarios' noise is a fraction of each
    sweep's or file's RMS).

    Returns
    -------
    problem : FitProblem
    truth : dict   {"hidden": ("QSY7", "QSY8") or None, "value": (QSY7, QSY8), "params"}
    """
    start = base_tir()
    truth = _randomised(rng, start, ("QSY1", "QSY3", "QSY4"))
    if values is None:
        values = (1.0 - rng.uniform(0.08, 0.20), -rng.uniform(0.2, 0.6))
    if hidden:
        truth["QSY7"], truth["QSY8"] = values
    fz0, p0 = start["FNOMIN"], start["NOMPRES"]
    fz = np.repeat([f * fz0 for f, _ in CONFOUNDED_PAIRS], len(CONFOUNDED_SPEEDS))
    pb = np.repeat([p for _, p in CONFOUNDED_PAIRS], len(CONFOUNDED_SPEEDS))
    vx = np.tile(CONFOUNDED_SPEEDS, len(CONFOUNDED_PAIRS))
    zeros = np.zeros_like(fz)
    clean = evaluate(truth, fz, zeros, zeros, zeros, vx, p=pb * 1e5, mode=111)["My"]
    value = clean / start["UNLOADED_RADIUS"]
    pair = np.repeat(np.arange(len(CONFOUNDED_PAIRS)), len(CONFOUNDED_SPEEDS))
    rms = np.sqrt(np.bincount(pair, value ** 2) / np.bincount(pair))[pair]
    value = value + noise * rms * rng.standard_normal(value.size)
    chars = pd.DataFrame({"quantity": "FxRR", "pi_bar": pb, "p_Pa": pb * 1e5, "Fz_N": fz,
                          "Vx_mps": vx, "value": value})
    ctx = Context(fz0=fz0, p0_bar=p0 / 1e5, tir=start)
    problem = _named(rolling_resistance(chars, ctx, form="old"), "RR")
    return problem, {"hidden": ("QSY7", "QSY8") if hidden else None,
                     "value": tuple(values) if hidden else None, "params": truth}


def make_session(rng: np.random.Generator, samples: int = 136_000, *, hidden: dict | None = None,
                 noise: float = 0.01, rho: float = 0.9, drift: float = 0.0) -> tuple[pd.DataFrame,
                                                                                    dict]:
    """A synthetic two-run trailer session of about ``samples`` samples at 100 Hz (TTC-like:
    pressure blocks 1.0, 0.85, 1.15 x NOMPRES; a cornering run with camber 0, 2, 4 deg and a
    drive/brake run at slip angles 0, 3, 6 deg and camber 0, 2 deg; loads 1.0, 0.5, 1.5, 1.25,
    0.75 x FNOMIN; one continuous sweep per set point).

    The forces come from the model at the actual load (set point with a slow 1 % wander), the
    load channel carries 0.3 % white measurement noise, the forces and moments AR(1) noise
    (lag-one ``rho``) of ``noise`` x each sweep's RMS; ``drift`` scales every force by
    (1 + drift tau) along the session (tau = -1 .. +1). ``hidden``: .tir values that the data
    have and the base (:func:`base_tir`) lacks.

    Returns
    -------
    frame : DataFrame  trailer columns (run, t, Fz, kappa, alpha, gamma, Vx, p, Fx, Fy, Mx, Mz)
    truth : dict       the .tir values that generated it
    """

    t = base_tir()
    truth = {**t, **(hidden or {})}
    fz0, p0 = t["FNOMIN"], t["NOMPRES"]
    plan = []  # (run, p, fz, gamma, alpha_set, kind)
    for run, cambers, alphas in (("cornering", (0.0, 2.0, 4.0), (None,)),
                                 ("drive_brake", (0.0, 2.0), (0.0, 3.0, 6.0))):
        for pf in (1.0, 0.85, 1.15):
            for g in cambers:
                for a in alphas:
                    for lf in (1.0, 0.5, 1.5, 1.25, 0.75):
                        plan.append((run, pf * p0, lf * fz0, g, a))
    m = max(9, samples // len(plan))
    s = np.linspace(0.0, 4.0, m)
    tri = np.where(s <= 1, s, np.where(s <= 3, 2 - s, s - 4))
    cols = {k: [] for k in ("run", "Fz", "kappa", "alpha", "gamma", "p")}
    for run, p, fz, g, a in plan:
        cols["run"].append(np.full(m, run))
        cols["Fz"].append(np.full(m, fz))
        cols["p"].append(np.full(m, p))
        cols["gamma"].append(np.full(m, np.deg2rad(g)))
        if a is None:
            cols["alpha"].append(np.deg2rad(12.0) * tri)
            cols["kappa"].append(np.zeros(m))
        else:
            cols["alpha"].append(np.full(m, np.deg2rad(a)))
            cols["kappa"].append(0.15 * tri)
    df = pd.DataFrame({k: np.concatenate(v) for k, v in cols.items()})
    n = len(df)
    df["t"] = np.concatenate([np.arange(m) / 100.0 + 10.0 * m / 100.0 * i
                              for i in range(len(plan))])
    df["Vx"] = 40.0 / 3.6
    wander = np.cumsum(rng.standard_normal(n)) / np.sqrt(n)
    actual = df["Fz"].to_numpy() * (1.0 + 0.01 * wander / max(np.abs(wander).max(), 1e-12))
    out = evaluate(truth, actual, df["kappa"].to_numpy(), df["alpha"].to_numpy(),
                   df["gamma"].to_numpy(), df["Vx"].to_numpy(), p=df["p"].to_numpy(), mode=111)
    tau = np.linspace(-1.0, 1.0, n)
    sweep = np.repeat(np.arange(len(plan)), m)
    for ch in ("Fx", "Fy", "Mx", "Mz"):
        df[ch] = _noise(rng, out[ch] * (1.0 + drift * tau), sweep, sweep, noise, rho)
    df["Fz"] = actual * (1.0 + 0.003 * rng.standard_normal(n))
    return df, truth
