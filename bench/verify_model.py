"""Print the forward model's worst agreement with the MFeval reference outputs.

Golden tables (MFeval 4.3, one call, FITTYP 61/62, useMode 111/211, with and without omega)
and the MFeval 4.0 sweep grids (3 tyres x 4 grids, modes 111/121; MF 6.2 rho/Rl/Cz against
the exact roots). Metric |d|/max(1, |ref|). The tests assert the same numbers; this script
reports them. The reference data are in tests/data/reference (see its PROVENANCE.md).

    python bench/verify_model.py
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from identify.io.tir import read_tir
from identify.model.evaluate import SolverOptions, evaluate

REFERENCE = Path(__file__).resolve().parents[1] / "tests" / "data" / "reference"
GOLDEN_COLUMNS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz", "kappa_out", "alpha_out", None, "phit_out",
                  None, "p_used", "Re", "rho", "2a", "t", "mux", "muy", "omega", "Rl", "2b",
                  "Mzr", "Cx", "Cy", "Cz", "Kya", "sigmax", "sigmay", None, "Kxk")


def _rel(a, b):
    return float(np.nanmax(np.abs(np.asarray(a) - b) / np.maximum(1.0, np.abs(b))))


def golden() -> dict[str, float]:
    worst: dict[str, float] = {}
    g = REFERENCE / "golden"
    for fittyp in (61, 62):
        P = read_tir(g / f"testA_{fittyp}.tir").params()
        for mode in (111, 211):
            for table, pts_file in (("gold", "pts.csv"), ("goldom", "pts_om.csv")):
                pts = np.loadtxt(g / pts_file, delimiter=",", ndmin=2)
                ref = np.loadtxt(g / f"{table}_{fittyp}_{mode}.csv", delimiter=",", ndmin=2)
                out = evaluate(P, pts[:, 0], pts[:, 1], pts[:, 2], pts[:, 3], pts[:, 5],
                               p=pts[:, 6], omega=pts[:, 7] if pts.shape[1] > 7 else None,
                               phit=pts[:, 4], mode=mode, solver=SolverOptions.mfeval_call())
                for j, name in enumerate(GOLDEN_COLUMNS):
                    if name is not None:
                        key = f"{name} (6.2)" if fittyp == 62 and name in ("rho", "Rl", "Cz") \
                            else name
                        worst[key] = max(worst.get(key, 0.0), _rel(out[name], ref[:, j]))
    return worst


def grids() -> dict[str, float]:
    worst: dict[str, float] = {}
    m = REFERENCE / "mfeval"
    for tyre in ("MagicFormula61_Paramerters", "MagicFormula62_Paramerters",
                 "reference_tire_tvd3"):
        P = read_tir(m / f"{tyre}.tir").params()
        for grid in ("pure_lat", "pure_long", "combined", "pure_lat_mode121"):
            df = pd.read_csv(m / f"{tyre}__{grid}.csv")
            out = evaluate(P, df.in_Fz, df.in_kappa, df.in_alpha, df.in_gamma, df.in_Vx,
                           p=df.in_p, mode=121 if grid.endswith("121") else 111)
            names = ["Fx", "Fy", "Fz", "Mx", "My", "Mz", "Re", "2a", "2b", "t", "mux", "muy",
                     "Kya", "Kxk", "sigmax", "sigmay", "Cx", "Cy"]
            if "62" in tyre:
                root = pd.read_csv(m / f"{tyre}__Rl_root.csv")
                root = root[root.grid == grid].sort_values("row")
                for name in ("rho", "Rl", "Cz"):
                    key = f"{name} (6.2, vs exact root)"
                    worst[key] = max(worst.get(key, 0.0),
                                     _rel(out[name], root[f"{name}_root"].to_numpy(float)))
            else:
                names += ["rho", "Rl", "Cz"]
            for name in names:
                worst[name] = max(worst.get(name, 0.0), _rel(out[name], df[name].to_numpy()))
    return worst


if __name__ == "__main__":
    for title, result in (("golden tables (MFeval 4.3)", golden()),
                          ("MFeval 4.0 sweep grids", grids())):
        print(f"{title}: worst |d|/max(1,|ref|) per output")
        print("  " + ", ".join(f"{k} {v:.1e}" for k, v in result.items()))
