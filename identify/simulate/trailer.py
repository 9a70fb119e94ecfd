"""Trailer sweeps from the Magic Formula: steady-state channel files with TYDEX channel names.

Per pressure, one file per sweep kind (``trailer/<sweep>_p<kPa>.csv``), ISO-W axes, SI units
(SLIPANGL and INCLANGL in rad, INFLPRES in Pa). Each load gets its own sweep; the sweeps follow
one another in RUNTIME. Noise goes on FX, FYW, MXW, MYW, MZW; FZW is the load the trailer
holds (the forces are computed at that load, so it stays noise-free).
"""
from __future__ import annotations

import numpy as np

from identify.model.modes import TRAILER_MODE
from identify.simulate.grid import Grid
from identify.simulate.model import Run, TyreModel

__all__ = ["trailer_runs", "TRAILER_CHANNELS", "TRAILER_NOISY"]

TRAILER_CHANNELS = ("RUNTIME", "LONGVEL", "WHROTSPD", "SLIPANGL", "LONGSLIP", "INCLANGL",
                    "INFLPRES", "FX", "FYW", "FZW", "MXW", "MYW", "MZW")
TRAILER_NOISY = ("FX", "FYW", "MXW", "MYW", "MZW")
_SAMPLE_RATE = 10.0  # [Hz] of the steady sweeps


def _triangle(amplitude: float, n: int) -> np.ndarray:
    """0 -> +a -> -a -> 0 in ``n`` equally spaced samples."""
    s = np.linspace(0.0, 4.0, n)
    return amplitude * np.where(s <= 1, s, np.where(s <= 3, 2 - s, s - 4))


def _sweeps(grid: Grid, kind: str) -> list[dict]:
    """The sweeps of one file, each a dict of equally long arrays (alpha, kappa, gamma, vx, fz)."""
    g, n = grid, grid.samples
    out = []
    for fz in g.trailer_loads:
        if kind == "cornering":
            out.append({"alpha": _triangle(np.deg2rad(g.alpha_max_deg), n.trailer_alpha)})
        elif kind == "braking_driving":
            out.append({"kappa": _triangle(g.kappa_max, n.trailer_kappa)})
        elif kind == "combined":
            out += [{"kappa": _triangle(g.combined_kappa_max, n.trailer_combined),
                     "alpha": np.full(n.trailer_combined, np.deg2rad(a))}
                    for a in g.combined_alpha_deg]
        elif kind == "camber":
            out.append({"gamma": _triangle(np.deg2rad(g.camber_sweep_deg), n.trailer_camber)})
            out += [{"alpha": _triangle(np.deg2rad(g.camber_alpha_max_deg), n.trailer_alpha),
                     "gamma": np.full(n.trailer_alpha, np.deg2rad(c))}
                    for c in g.camber_alpha_gamma_deg]
        elif kind == "rolling_resistance":
            out += [{"vx": np.full(n.trailer_rr, v)} for v in g.rr_speeds]
        for sweep in out:
            sweep.setdefault("fz", fz)
    for sweep in out:
        size = max(np.size(v) for v in sweep.values())
        for key in ("alpha", "kappa", "gamma"):
            sweep[key] = np.broadcast_to(sweep.get(key, 0.0), size)
        sweep["vx"] = np.broadcast_to(sweep.get("vx", g.trailer_speed), size)
        sweep["fz"] = np.broadcast_to(sweep["fz"], size)
    return out


def trailer_runs(model: TyreModel, grid: Grid) -> list[Run]:
    """Every trailer file: cornering, braking_driving, combined, camber, rolling_resistance
    at each pressure of ``grid.trailer_pressures_bar``."""
    runs = []
    for kind in ("cornering", "braking_driving", "combined", "camber", "rolling_resistance"):
        sweeps = _sweeps(grid, kind)
        cols = {k: np.concatenate([s[k] for s in sweeps]) for k in ("alpha", "kappa", "gamma",
                                                                    "vx", "fz")}
        n = cols["fz"].size
        # sweeps follow one another with a one-sample pause between them
        sizes = [s["fz"].size for s in sweeps]
        t = (np.arange(n) + np.repeat(np.arange(len(sweeps)), sizes)) / _SAMPLE_RATE
        for p in grid.trailer_pressures_bar:
            out = model.mf(cols["fz"], p, alpha=cols["alpha"], gamma=cols["gamma"],
                           kappa=cols["kappa"], vx=cols["vx"], mode=TRAILER_MODE)
            channels = {
                "RUNTIME": t, "LONGVEL": cols["vx"].astype(float), "WHROTSPD": out["omega"],
                "SLIPANGL": cols["alpha"].astype(float), "LONGSLIP": cols["kappa"].astype(float),
                "INCLANGL": cols["gamma"].astype(float), "INFLPRES": np.full(n, p * 1e5),
                "FX": out["Fx"], "FYW": out["Fy"], "FZW": cols["fz"].astype(float),
                "MXW": out["Mx"], "MYW": out["My"], "MZW": out["Mz"]}
            rid = f"{kind}_p{round(p * 100)}"
            cond = {"pressure_Pa": int(round(p * 1e5))}
            if kind != "rolling_resistance":
                cond["speed_mps"] = float(grid.trailer_speed)
            runs.append(Run(rid, f"trailer/{rid}.csv", "trailer", kind, cond, channels,
                            TRAILER_NOISY))
    return runs
