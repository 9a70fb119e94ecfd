"""One-off calibration of the simulator's default coefficients to the thesis table.

``python -m identify.simulate.calibrate [thesis_characteristics.csv]`` fits, by relative least
squares (scipy), the relations the simulator uses to the real Flatplank characteristics of the
thesis tyre (225/50 R17, op het Veld 2007, chapter 4):

- CFz: qFz1, qFz2, qFz3;
- CFx: nominal, pCFx1, pCFx3 at Fz0 = 4 kN (pCFx2 = 0);
- CFy and sigma_y together: CFy nominal, pCFy1, pCFy3 (Fz0 = 5 kN, pCFy2 = 0) and PKY1, PKY2,
  PPY1, PPY2 (PKY4 = 2), so that sigma_y = |Kya|/CFy matches the measured relaxation lengths;
- Re: Q_RE0, BREFF, DREFF, FREFF with the vertical stiffness of the CFz fit.

It prints the numbers (pasted into :mod:`identify.simulate.coefficients`) and the worst relative
deviation per quantity. Not used at run time.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from identify.model import relations as rel

P0_BAR = 2.5
FZ0 = 5000.0
R0 = 0.3205


def _cells(table: pd.DataFrame, quantity: str):
    t = table[table["quantity"] == quantity]
    return (rel.dpi(t["pi_bar"].to_numpy(float), P0_BAR), t["Fz_N"].to_numpy(float),
            t["value"].to_numpy(float))


def fit_all(table: pd.DataFrame) -> dict[str, dict[str, float]]:
    """Fit every default relation to a thesis-style characteristic table; return coefficients."""
    out: dict[str, dict[str, float]] = {}
    dp, fz, v = _cells(table, "CFz")
    r = least_squares(lambda q: rel.cfz_qfz_at_load(fz, dp, q[0] * 1e5, q[1] * 1e6, q[2]) / v - 1,
                      [2.0, 1.0, 0.5])
    out["CFz"] = {"qfz1": r.x[0] * 1e5, "qfz2": r.x[1] * 1e6, "qfz3": r.x[2]}

    dp, fz, v = _cells(table, "CFx")
    # the quadratic-load form (pCFx2 <= 0): the thesis CFx flattens at high load
    r = least_squares(lambda q: rel.load_pressure_stiffness(fz, dp, q[0] * 1e5, q[1], q[3], q[2],
                                                            4000.0) / v - 1,
                      [2.0, 0.2, 0.2, 0.0], bounds=([1, -1, 0, -0.6], [3, 1, 1, 0]))
    out["CFx"] = {"nominal": r.x[0] * 1e5, "p1": r.x[1], "p2": r.x[3], "p3": r.x[2]}

    dp_c, fz_c, v_c = _cells(table, "CFy")
    dp_s, fz_s, v_s = _cells(table, "sigma_y")

    def res_y(q):
        cfy = rel.load_pressure_stiffness(fz_c, dp_c, q[0] * 1e5, q[1], 0, q[2], FZ0)
        cfy_s = rel.load_pressure_stiffness(fz_s, dp_s, q[0] * 1e5, q[1], 0, q[2], FZ0)
        sig = rel.sigma_ratio(rel.kya(fz_s, dp_s, q[3], q[4], q[5], q[6], FZ0), cfy_s)
        return np.concatenate([cfy / v_c - 1, sig / v_s - 1])

    # PKY2 <= 3 keeps the Kya peak at a plausible load (unbounded, the fit runs off to a nearly
    # linear Kya with PKY2 ~ 5.6 for a 1 % better sigma_y)
    r = least_squares(res_y, [1.4, 0.2, 0.5, -20.0, 1.5, 0.0, 0.5],
                      bounds=([0.5, -1, 0, -100, 0.5, -1, -1], [3, 1, 1, -1, 3, 1.5, 2]))
    out["CFy"] = {"nominal": r.x[0] * 1e5, "p1": r.x[1], "p3": r.x[2]}
    out["Kya"] = {"PKY1": r.x[3], "PKY2": r.x[4], "PPY1": r.x[5], "PPY2": r.x[6]}

    dp, fz, v = _cells(table, "Re")
    cz0 = rel.mf_from_qfz(out["CFz"]["qfz1"], out["CFz"]["qfz2"], out["CFz"]["qfz3"], R0,
                          FZ0)["VERTICAL_STIFFNESS"]
    pfz1 = out["CFz"]["qfz3"]

    def re_model(q, fz, dp):
        cz = cz0 * (1 + pfz1 * dp)
        return R0 * q[0] - (FZ0 / cz) * (q[2] * np.arctan(q[1] * fz / FZ0) + q[3] * fz / FZ0)

    r = least_squares(lambda q: re_model(q, fz, dp) / v - 1, [1.01, 8.0, 0.25, 0.05],
                      bounds=([0.9, 4.0, 0.1, 0.0], [1.1, 12.0, 0.5, 0.2]))  # typical shape
    out["Re"] = {"Q_RE0": r.x[0], "BREFF": r.x[1], "DREFF": r.x[2], "FREFF": r.x[3]}
    return out


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0]) if argv else (Path(__file__).resolve().parents[2] / "measurements"
                                       / "thesis-225-50R17" / "characteristics.csv")
    table = pd.read_csv(path)
    for name, coefficients in fit_all(table).items():
        print(name, {k: float(f"{v:.6g}") for k, v in coefficients.items()})


if __name__ == "__main__":  # pragma: no cover
    main()
