"""Flatplank runs without rolling: vertical, locked-hub stiffness (x and y) and parking.

Each generator returns :class:`~identify.simulate.model.Run` objects whose channels are the raw
hub bridges (the Flatplank hub transform of docs/procedures.md inverted) plus the rig's motion
channels.
"""
from __future__ import annotations

import numpy as np

from identify.model.relations import fz_qfz
from identify.simulate.artefacts import Artefacts, saturate, startup_transient, stick_slip
from identify.simulate.grid import Grid
from identify.simulate.model import Run, TyreModel
from identify.simulate.rig import BRIDGES, bridges_from_contact

__all__ = ["run_name", "assemble", "vertical_runs", "locked_hub_runs", "parking_runs"]


def run_name(test: str, p_bar: float, fz: float, start: int, suffix: str = "") -> str:
    """File stem ``<test>_p<bar*100>_fz<N>_s<start><suffix>`` (docs/measurement-folder.md)."""
    return f"{test}_p{round(p_bar * 100)}_fz{round(fz)}_s{start}{suffix}"


def conditions(p_bar: float, fz: float, start: int, **extra) -> dict:
    """Manifest conditions of a Flatplank run."""
    return {"pressure_Pa": int(round(p_bar * 1e5)), "load_N": int(round(fz)),
            "start_position": int(start), **{k: float(v) for k, v in extra.items()}}


def assemble(model: TyreModel, run_id: str, test: str, cond: dict, *, t, plank_x=0.0,
             wheel_angle=0.0, psi=0.0, hub_z=0.0, gamma=0.0, rl, fx=0.0, fy=0.0, fz, mx=0.0,
             mz=0.0) -> Run:
    """Build a Flatplank run from contact-patch forces and rig motion (arrays broadcast to t)."""
    t = np.asarray(t, dtype=float)
    b = {k: np.broadcast_to(np.asarray(v, dtype=float), t.shape).copy() for k, v in dict(
        plank_x=plank_x, wheel_angle=wheel_angle, psi=psi, hub_z=hub_z, gamma=gamma, rl=rl,
        fx=fx, fy=fy, fz=fz, mx=mx, mz=mz).items()}
    phi_wheel, phi_plank = model.rig.camber_split(b["gamma"])
    gamma_used = phi_wheel + phi_plank  # exactly what a loader computes from the channels
    br = bridges_from_contact(b["fx"], b["fy"], b["fz"], b["mx"], b["mz"], gamma_used, b["rl"],
                              model.rig.hub_a, model.rig.hub_b)
    # "+ 0.0" turns the -0.0 of sign flips into 0.0 (a "-0" in a file looks like a defect)
    channels = {"time": t, **{k: br[k] + 0.0 for k in BRIDGES}, "plank_x": b["plank_x"],
                "wheel_angle": b["wheel_angle"], "psi": b["psi"], "hub_z": b["hub_z"],
                "phi_wheel": phi_wheel, "phi_plank": phi_plank, "loaded_radius": b["rl"]}
    contact = {"Fx": b["fx"], "Fy": b["fy"], "Fz": b["fz"], "Mx": b["mx"], "My": br["My"],
               "Mz": b["mz"], "gamma": gamma_used}
    return Run(run_id, f"flatplank/{run_id}.csv", "flatplank", test, cond, channels, BRIDGES,
               contact)


def vertical_runs(model: TyreModel, grid: Grid, art: Artefacts) -> list[Run]:
    """Press down at constant hub speed to the deflection of ``rig.vertical_max_load``, unload."""
    rig, v = model.rig, model.relations.vertical
    runs = []
    for p in grid.pressures_bar:
        dp = model.dp(p)
        for s in range(1, grid.starts + 1):
            k = rig.start_factor(s, grid.starts)
            rho_max = float(v.rho(rig.vertical_max_load / k, dp))
            n = grid.samples.vertical
            n_up = n // 2 + 1
            rho_up = np.linspace(0.0, rho_max, n_up)
            rho_dn = np.linspace(rho_max, 0.0, n - n_up + 1)[1:]
            rho = np.concatenate([rho_up, rho_dn])
            path = np.concatenate([rho_up, 2 * rho_max - rho_dn])
            fz = k * fz_qfz(rho, dp, v.qfz1, v.qfz2, v.qfz3)
            unloading = np.arange(n) >= n_up
            fz = np.where(unloading, fz * (1 - rig.vertical_hysteresis * (1 - rho / rho_max)), fz)
            rid = run_name("vertical", p, rig.vertical_max_load, s)
            runs.append(assemble(
                model, rid, "vertical", conditions(p, rig.vertical_max_load, s),
                t=path / rig.vertical_speed, wheel_angle=rig.start_phase(s, grid.starts),
                hub_z=rho, rl=model.r0 * model.params["Q_RE0"] - rho, fz=fz))
    return runs


def _stick_amplitude(dp: float) -> float:
    # stick-slip is strongest at low pressure (thesis: low pressure / low load)
    return float(np.clip(0.08 * (1 - 2 * dp), 0.02, 0.15))


def locked_hub_runs(model: TyreModel, grid: Grid, art: Artefacts, axis: str) -> list[Run]:
    """Hub locked, plank moved: ``axis`` "x" (longitudinal, loads ``grid.long_loads``) or "y"
    (tyre turned 90 deg, lateral, loads ``grid.loads``).

    Force = saturate(C u, mu Fz) with u the plank travel minus start-up slack, a decaying
    start-up oscillation and saw-tooth stick-slip once saturated (as enabled in ``art``).
    """
    rig = model.rig
    test, loads, rel, mu = (("longitudinal_stiffness", grid.long_loads, model.relations.cfx,
                             rig.mu_x) if axis == "x" else
                            ("lateral_stiffness", grid.loads, model.relations.cfy, rig.mu_y))
    runs = []
    for p in grid.pressures_bar:
        dp = float(model.dp(p))
        for fz in loads:
            for s in range(1, grid.starts + 1):
                c = float(rel(fz, dp)) * rig.start_factor(s, grid.starts)
                f_sat = mu * fz
                x_sat = f_sat / c
                x = np.linspace(0.0, 2.5 * x_sat, grid.samples.stiffness)
                u, osc = x, 0.0
                if art.transients:
                    u, osc = startup_transient(x, slack=0.05 * x_sat, amplitude=0.03,
                                               decay=0.06 * x_sat, period=0.04 * x_sat)
                force = saturate(c * u, f_sat, rig.linear_fraction)
                if art.stick_slip:
                    force = force * stick_slip(x, force / f_sat, _stick_amplitude(dp),
                                               0.15 * x_sat)
                force = force + osc * f_sat
                rid = run_name(test, p, fz, s)
                kw = {"fx": force} if axis == "x" else {"fy": force, "psi": np.pi / 2}
                runs.append(assemble(
                    model, rid, test, conditions(p, fz, s), t=x / rig.stiffness_speed,
                    plank_x=x, wheel_angle=rig.start_phase(s, grid.starts),
                    hub_z=float(model.rho(fz, p)), rl=float(model.loaded_radius(fz, p)), fz=fz,
                    **kw))
    return runs


def parking_runs(model: TyreModel, grid: Grid, art: Artefacts) -> list[Run]:
    """Standing tyre steered 0 -> +R -> -R -> +R: a hysteresis loop with slope CMz at psi = 0.

    Mz = saturate(CMz psi, Ms) + h, where the branch offset h moves from -d Mh to +d Mh after
    each reversal (d = steering direction) over psi_c = 2 Mh/CMz, so the torque drops with
    stiffness ~CMz after a reversal and both branches cross psi = 0 with slope CMz.
    The first branch is the virgin curve (h rises from 0 to Mh).
    """
    rig = model.rig
    r = rig.parking_range
    runs = []
    for p in grid.pressures_bar:
        dp = float(model.dp(p))
        for fz in grid.parking_loads:
            for s in range(1, grid.starts + 1):
                cmz = float(model.relations.cmz(fz, dp)) * rig.start_factor(s, grid.starts)
                m_sat = (rig.parking_torque * (fz / model.fz0) ** rig.parking_exponent
                         * (1 + rig.parking_pressure * dp))
                m_h = rig.parking_hysteresis * m_sat
                psi_c = 2 * m_h / cmz
                travel = np.linspace(0.0, 5 * r, grid.samples.parking)
                seg = np.searchsorted([r, 3 * r], travel, side="left")
                psi = np.choose(seg, [travel, 2 * r - travel, travel - 4 * r])
                since = np.choose(seg, [travel, travel - r, travel - 3 * r])
                d = np.choose(seg, [1.0, -1.0, 1.0])
                h = np.where(seg == 0, m_h * (1 - np.exp(-since / psi_c)),
                             d * m_h * (1 - 2 * np.exp(-since / psi_c)))
                g = saturate(cmz * psi, m_sat, rig.linear_fraction)
                if art.stick_slip:
                    g = g * stick_slip(travel, g / m_sat, _stick_amplitude(dp), 0.1 * r)
                mz = g + h
                if art.transients:
                    mz = mz + 0.04 * m_sat * np.exp(-travel / (0.03 * r)) * np.sin(
                        2 * np.pi * travel / (0.02 * r))
                rid = run_name("parking", p, fz, s)
                runs.append(assemble(
                    model, rid, "parking", conditions(p, fz, s), t=travel / rig.turn_rate,
                    wheel_angle=rig.start_phase(s, grid.starts), psi=psi,
                    hub_z=float(model.rho(fz, p)), rl=float(model.loaded_radius(fz, p)), fz=fz,
                    mz=mz))
    return runs
