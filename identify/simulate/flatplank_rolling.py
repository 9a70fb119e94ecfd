"""Flatplank rolling runs: lateral relaxation (1 deg and its 0-deg reference), free rolling and
camber (with its 0-deg reference).

A run stands for a few samples, then the plank moves at ``rig.rolling_speed``. The Magic Formula
forces and moments at the run's slip and camber build up with the rolled distance x as
F (1 - exp(-x/sigma_y)); the wheel turns at Vx cos(alpha)/Re. Each start position adds its own
once-per-revolution non-uniformity, identical in a run and its reference (which therefore
carries the same ply-steer, conicity and non-uniformity and removes them on subtraction).
"""
from __future__ import annotations

import numpy as np

from identify.simulate.artefacts import Artefacts
from identify.simulate.flatplank import assemble, conditions, run_name
from identify.simulate.grid import Grid
from identify.simulate.model import Run, TyreModel

__all__ = ["relaxation_runs", "free_rolling_runs", "camber_runs", "short_cell"]

_MOMENTS = ("Fy", "Mz", "Mx")


def short_cell(model: TyreModel, grid: Grid) -> tuple[float, float]:
    """(pressure [bar], load [N]) of the grid cell with the longest relaxation length."""
    p, fz = np.meshgrid(grid.pressures_bar, grid.loads, indexing="ij")
    sigma = model.sigma_y(fz, p)
    k = np.unravel_index(np.argmax(sigma), sigma.shape)
    return float(p[k]), float(fz[k])


def _rolling(model: TyreModel, grid: Grid, run_id: str, test: str, cond: dict, *, p: float,
             fz: float, start: int, alpha: float, gamma: float, distance: float, n_roll: int,
             steady: dict, reference: dict, gain: float, re: float, sigma: float) -> Run:
    """One rolling run; ``steady`` and ``reference`` map Fy, Mz, Mx to their steady values at
    the run's and at the 0-deg conditions; the part that differs is scaled by ``gain``.
    ``re`` [m] and ``sigma`` [m] are the cell's rolling radius and relaxation length."""
    rig = model.rig
    n_lead = grid.samples.lead_in
    dt = distance / rig.rolling_speed / (n_roll - 1)
    t = np.arange(n_lead + n_roll) * dt
    x = np.clip(t - n_lead * dt, 0.0, None) * rig.rolling_speed
    phase = rig.start_phase(start, grid.starts)
    wheel = phase + x * np.cos(alpha) / re
    build = -np.expm1(-x / sigma)
    # non-uniformity tied to the rolled distance, so a run and its reference share it exactly
    ripple = np.cos(phase + x / re)
    forces = {k: (reference[k] + gain * (steady[k] - reference[k])) * build for k in _MOMENTS}
    return assemble(
        model, run_id, test, cond, t=t, plank_x=x, wheel_angle=wheel, psi=alpha,
        hub_z=float(model.rho(fz, p)), rl=float(model.loaded_radius(fz, p)), gamma=gamma,
        fx=rig.ripple_fx * ripple, fz=fz * (1 + rig.ripple_fz * ripple),
        fy=forces["Fy"] + rig.ripple_fy * ripple, mz=forces["Mz"] + rig.ripple_mz * ripple,
        mx=forces["Mx"] + rig.ripple_mx * ripple)


def _steady(model: TyreModel, fz: float, p: float, alpha, gamma) -> tuple[list[dict], dict]:
    """Steady Fy, Mz, Mx at each (alpha, gamma) pair [rad], and the cell's Re and sigma_y [m]."""
    alpha = np.concatenate([[0.0], np.asarray(alpha, float)])
    out = model.mf(fz, p, alpha=alpha, gamma=np.concatenate([[0.0], np.asarray(gamma, float)]))
    cell = {"re": float(out["Re"][0]),
            "sigma": float(np.abs(out["Kya"][0]) / model.relations.cfy(fz, model.dp(p)))}
    return [{k: float(out[k][i]) for k in _MOMENTS} for i in range(1, alpha.size)], cell


def relaxation_runs(model: TyreModel, grid: Grid, art: Artefacts) -> list[Run]:
    """1-deg relaxation runs and their 0-deg references (suffix ``_a1`` / ``_a0``)."""
    rig = model.rig
    alpha = np.deg2rad(grid.relaxation_deg)
    short = short_cell(model, grid) if art.short_relaxation else None
    runs = []
    for p in grid.pressures_bar:
        for fz in grid.loads:
            (ref, slip), cell = _steady(model, fz, p, [0.0, alpha], [0.0, 0.0])
            lengths = rig.short_lengths if short == (p, fz) else rig.relaxation_lengths
            distance = np.ceil(lengths * cell["sigma"] * 10) / 10
            for s in range(1, grid.starts + 1):
                for a, steady, tag in ((alpha, slip, grid.relaxation_deg), (0.0, ref, 0)):
                    rid = run_name("relaxation", p, fz, s, f"_a{tag:g}")
                    cond = conditions(p, fz, s, gamma_deg=0.0, slip_angle_deg=np.rad2deg(a),
                                      speed_mps=rig.rolling_speed)
                    runs.append(_rolling(model, grid, rid, "relaxation", cond, p=p, fz=fz,
                                         start=s, alpha=a, gamma=0.0, distance=distance,
                                         n_roll=grid.samples.rolling, steady=steady,
                                         reference=ref, gain=1.0, **cell))
    return runs


def free_rolling_runs(model: TyreModel, grid: Grid, art: Artefacts) -> list[Run]:
    """Free rolling at zero slip and camber over one wheel revolution (Re = Vx/Omega)."""
    runs = []
    for p in grid.pressures_bar:
        for fz in grid.loads:
            (ref,), cell = _steady(model, fz, p, [0.0], [0.0])
            distance = 2 * np.pi * cell["re"]
            for s in range(1, grid.starts + 1):
                rid = run_name("free_rolling", p, fz, s)
                cond = conditions(p, fz, s, gamma_deg=0.0, slip_angle_deg=0.0,
                                  speed_mps=model.rig.rolling_speed)
                runs.append(_rolling(model, grid, rid, "free_rolling", cond, p=p, fz=fz,
                                     start=s, alpha=0.0, gamma=0.0, distance=distance,
                                     n_roll=grid.samples.free_rolling, steady=ref,
                                     reference=ref, gain=1.0, **cell))
    return runs


def camber_runs(model: TyreModel, grid: Grid, art: Artefacts) -> list[Run]:
    """Free rolling at each camber angle of the grid (the 0-deg run is the reference, ``_g0``).

    With ``art.asymmetry`` the camber-induced part at negative camber is scaled by
    (1 + asymmetry), as a hub calibration error between +gamma and -gamma would do.
    """
    rig = model.rig
    gammas = np.deg2rad(np.asarray(grid.camber_deg, dtype=float))
    runs = []
    for p in grid.pressures_bar:
        for fz in grid.loads:
            steady, cell = _steady(model, fz, p, np.zeros(gammas.size + 1),
                                   np.concatenate([[0.0], gammas]))
            ref, steady = steady[0], steady[1:]
            distance = np.ceil(rig.relaxation_lengths * cell["sigma"] * 10) / 10
            for g_deg, g, st in zip(grid.camber_deg, gammas, steady):
                gain = 1.0 + art.asymmetry if g < 0 else 1.0
                for s in range(1, grid.starts + 1):
                    rid = run_name("camber", p, fz, s, f"_g{g_deg:g}")
                    cond = conditions(p, fz, s, gamma_deg=g_deg, slip_angle_deg=0.0,
                                      speed_mps=rig.rolling_speed)
                    runs.append(_rolling(model, grid, rid, "camber", cond, p=p, fz=fz, start=s,
                                         alpha=0.0, gamma=g, distance=distance,
                                         n_roll=grid.samples.camber, steady=st, reference=ref,
                                         gain=gain, **cell))
    return runs
