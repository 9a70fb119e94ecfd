"""The true characteristics a simulated folder was made from (characteristic-table schema).

One record per quantity, pressure and load (and speed, camber angle or mode where that applies):
``quantity, pi_bar, Fz_N, value, unit`` plus ``Vx_mps``, ``gamma_deg`` or ``mode``. The values
come from the same :class:`~identify.simulate.model.TyreModel` calls the runs use.
"""
from __future__ import annotations

import numpy as np

from identify.model.modes import TRAILER_MODE
from identify.model.relations import RING_MODES
from identify.simulate.grid import Grid
from identify.simulate.model import TyreModel

__all__ = ["UNITS", "characteristics", "eigenfrequency_rows"]

#: Unit of each quantity (docs/loaded-tables.md).
UNITS = {"CFz": "N/m", "CFx": "N/m", "CFy": "N/m", "CMz": "N*m/rad", "sigma_y": "m",
         "sigma_x": "m", "Re": "m", "FxRR": "N", "Fy_gamma": "N", "Mz_gamma": "N*m",
         "Mx_gamma": "N*m", "f_nat": "Hz"}


def _row(quantity: str, p_bar: float, fz: float, value: float, **extra) -> dict:
    return {"quantity": quantity, "pi_bar": float(p_bar), "Fz_N": float(fz),
            "value": float(value), "unit": UNITS[quantity], **extra}


def eigenfrequency_rows(model: TyreModel, pressures_bar) -> list[dict]:
    """Free-hanging (fixed rim, Fz = 0) rigid-ring eigenfrequencies at each pressure [Hz]."""
    ring = model.relations.ring
    return [_row("f_nat", p, 0.0, float(ring.frequency(mode, model.dp(p))), mode=mode)
            for p in pressures_bar for mode in RING_MODES]


def characteristics(model: TyreModel, grid: Grid) -> list[dict]:
    """Every true characteristic of the grid, as records of the characteristic table."""
    rel = model.relations
    rows: list[dict] = []
    loads = np.asarray(grid.loads, dtype=float)
    gammas = np.asarray([g for g in grid.camber_deg if g != 0], dtype=float)
    for p in grid.pressures_bar:
        dp = float(model.dp(p))
        for q, fzs, values in (
                ("CFz", loads, rel.vertical.cfz_at_load(loads, dp)),
                ("CFx", grid.long_loads, rel.cfx(np.asarray(grid.long_loads), dp)),
                ("CFy", loads, rel.cfy(loads, dp)),
                ("CMz", grid.parking_loads, rel.cmz(np.asarray(grid.parking_loads), dp)),
                ("sigma_y", loads, model.sigma_y(loads, p)),
                ("Re", loads, model.re(loads, p))):
            rows += [_row(q, p, fz, v) for fz, v in zip(fzs, np.atleast_1d(values))]
        if gammas.size:
            g = np.deg2rad(np.concatenate([[0.0], gammas]))
            out = model.mf(loads[:, None], p, gamma=g[None, :])
            for name, q in (("Fy", "Fy_gamma"), ("Mz", "Mz_gamma"), ("Mx", "Mx_gamma")):
                delta = out[name][:, 1:] - out[name][:, :1]
                rows += [_row(q, p, fz, delta[i, j], gamma_deg=float(gammas[j]))
                         for i, fz in enumerate(loads) for j in range(gammas.size)]
    tl = np.asarray(grid.trailer_loads, dtype=float)
    speeds = np.asarray(grid.rr_speeds, dtype=float)
    for p in grid.trailer_pressures_bar:
        my = model.mf(tl[:, None], p, vx=speeds[None, :], mode=TRAILER_MODE)["My"]
        rows += [_row("FxRR", p, fz, my[i, j] / model.r0, Vx_mps=float(v))
                 for i, fz in enumerate(tl) for j, v in enumerate(speeds)]
    rows += eigenfrequency_rows(model, grid.eigen_pressures_bar)
    return rows
