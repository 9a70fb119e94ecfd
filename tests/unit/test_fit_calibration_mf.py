"""Calibration of the MCMC credible intervals of the MF slip-coefficient stages (issue 5,
acceptance 3), behind the trials marker.

Per stage: 40 seeded trailer data sets from known coefficients (the recovery truth of
tests/unit/test_fit_mf_stages.py) with 1 % noise -- the simulator's definition, a standard deviation
of 1 % of each channel's RMS over its sweep (identify.simulate.artefacts) -- each fitted as
``mfid fit`` does (fit_mf, one stage, the other stages' coefficients at the truth) and sampled
with stage_mcmc; the 90 % credible interval must hold the true coefficient in >= 85 % of
(trials x free coefficients) and every chain must pass 50 autocorrelation times.

Design per trial (modest, like one trailer session): 3 pressures x 3 loads, as the recovery
tests (Fy0: five loads of 0.4-2 Fz0, see STAGE_LOADS_N); longitudinal kappa sweeps at 2
cambers, lateral alpha sweeps at 3 cambers, combined kappa sweeps at 4 slip angles and 2
cambers as in the recovery tests (21 points each, denser near zero slip where the slip
stiffnesses are measured), free
rolling at 3 speeds; each sweep is a run.

Run: ``pytest -m trials tests/unit/test_fit_calibration_mf.py -s``.
"""
from __future__ import annotations

import time
import zlib

import numpy as np
import pandas as pd

from identify.fit.mf.stages import fit_mf, stage_mcmc
from identify.model.evaluate import evaluate
from tests.unit.test_fit_calibration import N_TRIALS, Tally
from tests.unit.test_fit_mf_stages import _truth

SLIP_STAGES = ("Fx0", "Fy0", "Mz0", "Fx", "Fy", "Mz", "Mx", "My")
"""The slip-coefficient stages (the geometry stage fits Re, not a slip coefficient)."""
NOISE = 0.01
PRESSURES_BAR = (1.9, 2.5, 3.0)
LOADS_N = (3000.0, 5000.0, 7000.0)
N_KAPPA = 21
N_ALPHA = 21
STAGE_LOADS_N = {"Fy0": (2000.0, 4000.0, 6000.0, 8000.0, 10000.0)}
"""Stages whose coefficients need a wider load range than LOADS_N. Fy0: the cornering
stiffness Kya = PKY1 Fz0 sin(PKY4 atan(Fz / (PKY2 Fz0))) peaks at PKY2 Fz0 = 15 kN for the
truth; loads of 3-7 kN see only its nearly straight start, so PKY1, PKY2 and PKY4 lie on a
curved ridge (chains need tau ~ 1000-2000 steps). Loads of 0.4-2 Fz0, the usual trailer
range, bend the curve enough to separate them."""
MAX_STEPS = 100_000
"""Chain cap for the trials: long enough for every stage's 50-tau rule."""


def design(pressures=PRESSURES_BAR, loads=LOADS_N, n_kappa=N_KAPPA,
           n_alpha=N_ALPHA) -> pd.DataFrame:
    """Operating points of one trailer session; one run per sweep."""
    d = np.deg2rad

    def sweep(limit, n):  # denser near zero slip, where the slip stiffness is measured
        x = np.linspace(-1.0, 1.0, n)
        return limit * x * np.abs(x)
    kappa, alpha = sweep(0.3, n_kappa), d(sweep(12.0, n_alpha))
    frames = []

    def add(run, **cols):
        frames.append(pd.DataFrame({"run": run, "Vx": 16.7, "kappa": 0.0, "alpha": 0.0,
                                    "gamma": 0.0, **cols}))

    for pb in pressures:
        for fz in loads:
            tag = f"p{pb:g}_fz{fz:g}"
            for g in (0.0, 4.0):
                add(f"long_{tag}_g{g:g}", p=pb * 1e5, Fz=fz, kappa=kappa, gamma=d(g))
            for g in (-5.0, 0.0, 5.0):
                add(f"lat_{tag}_g{g:g}", p=pb * 1e5, Fz=fz, alpha=alpha, gamma=d(g))
            for g in (0.0, 4.0):
                for a in (-3.0, 2.0, 5.0, 9.0):
                    add(f"comb_{tag}_g{g:g}_a{a:g}", p=pb * 1e5, Fz=fz,
                        kappa=sweep(0.25, n_kappa), alpha=d(a), gamma=d(g))
            add(f"rr_{tag}", p=pb * 1e5, Fz=fz, Vx=np.array([5.0, 15.0, 25.0]))
    return pd.concat(frames, ignore_index=True)


def simulate(P, points: pd.DataFrame) -> pd.DataFrame:
    out = evaluate(P, points["Fz"].to_numpy(), points["kappa"].to_numpy(),
                   points["alpha"].to_numpy(), points["gamma"].to_numpy(),
                   points["Vx"].to_numpy(), p=points["p"].to_numpy(), mode=211)
    return points.assign(**{q: out[q] for q in ("Fx", "Fy", "Mz", "Mx", "My")})


def add_noise(clean: pd.DataFrame, seed: int) -> pd.DataFrame:
    """Noise of 1 % of each channel's RMS over its run (sweep). Each run draws from its own
    generator, seeded by (seed, run name), so a stage's data do not change when runs it does
    not use are added to the design."""
    out = clean.copy()
    channels = ["Fx", "Fy", "Mz", "Mx", "My"]
    for run, rows in clean.groupby("run", sort=False).indices.items():
        rng = np.random.default_rng([seed, zlib.crc32(str(run).encode())])
        x = clean[channels].to_numpy(float)[rows]
        rms = np.sqrt(np.mean(x ** 2, axis=0))
        out.iloc[rows, [out.columns.get_loc(c) for c in channels]] = (
            x + NOISE * rms * rng.standard_normal(x.shape))
    return out


def calibrate_stage(stage: str, n_trials: int = N_TRIALS, seed0: int = 2000,
                    points: pd.DataFrame | None = None, verbose: bool = False,
                    reparam: bool = True, free: dict[str, list[str]] | None = None,
                    label: str | None = None) -> dict:
    """Fit and sample ``stage`` on ``n_trials`` seeded noisy data sets (``reparam``: the Fy0
    cornering-stiffness reparametrisation of stage_mcmc) and count the 90 % intervals that
    hold the truth; prints one line and returns the tally's summary (named ``label``, default
    ``MF-<stage>``). ``free``: fit_mf's coefficients to free (default the stage's own)."""
    truth = _truth()
    if points is None:
        points = design(loads=STAGE_LOADS_N.get(stage, LOADS_N))
    clean = simulate(truth, points)
    t0 = time.perf_counter()
    tally, free_sizes, n_points = Tally(), [], 0
    for seed in range(n_trials):
        noisy = add_noise(clean, seed0 + seed)
        mf = fit_mf(noisy, truth, stages=(stage,), seed=seed, free=free)
        result = stage_mcmc(noisy, mf, stage, seed=seed, max_steps=MAX_STEPS, reparam=reparam)
        m = result.mcmc
        n_points = result.n_points
        free_sizes.append(len(result.free))
        tally.add(m, result.free, truth)
        if verbose:
            print(f"  trial {seed}: {len(result.free)} free, {m.n_steps} steps, tau "
                  f"{max(m.tau.values()):.0f}, acceptance {m.acceptance:.2f}, "
                  f"{m.seconds:.0f} s mcmc, {result.seconds:.0f} s fit, hits so far "
                  f"{tally.hits}/{tally.total}", flush=True)
    seconds = time.perf_counter() - t0
    n_free = int(np.median(free_sizes))
    label = label or f"MF-{stage}"
    print(f"\n{label} ({n_points} points, {n_free} free): {tally.line()}; {seconds:.0f} s;"
          f" misses by coefficient {tally.misses}")
    return dict(tally.summary(label, seconds), n_points=n_points, n_free=n_free)


def exact_linear_posterior(problem, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and sd of the flat-prior posterior of a problem that is linear in its free
    coefficients (the combined Mz stage in SSZ1..4): the generalised least-squares estimate
    (noise weights at the ordinary least-squares optimum) and s^2 (A'A)^-1, A the
    noise-weighted design matrix (columns by unit steps from ``x0``, exact for a linear
    model), s^2 the residual variance. With ~1000 points the Student-t of
    the unknown noise level is Gaussian to < 0.1 %."""
    f0 = problem.predict(x0)
    cols = np.column_stack([problem.predict(x0 + e) - f0 for e in np.eye(x0.size)])
    beta = np.linalg.lstsq(cols, problem.measured - f0, rcond=None)[0]
    # the noise weights the MCMC uses: at the least-squares optimum (FitProblem.noise_weights)
    w = problem.noise_weights(x0 + beta)
    a, b = cols * w[:, None], (problem.measured - f0) * w
    beta = np.linalg.lstsq(a, b, rcond=None)[0]
    r = b - a @ beta
    return x0 + beta, np.sqrt(r @ r / (b.size - x0.size) * np.diag(np.linalg.inv(a.T @ a)))
