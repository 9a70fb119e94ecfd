"""The whole forward model: operating points in, every MFeval output out.

``evaluate`` is the pure-numpy reference path. It is vectorised over points: no Python loop
over points anywhere (the only loops are the fixed-point and secant iterations, which act on
whole arrays).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from identify.core.errors import InputError
from identify.model import aligning, lateral, longitudinal, moments, vertical
from identify.model.modes import UseMode
from identify.model.state import prepare

INPUT_COLUMNS = ("Fz", "kappa", "alpha", "gamma", "Vx", "p")
OPTIONAL_INPUT_COLUMNS = ("phit", "omega")
OUTPUT_COLUMNS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz", "Re", "rho", "2a", "t", "mux", "muy",
                  "omega", "Rl", "2b", "Mzr", "Cx", "Cy", "Cz", "Kya", "sigmax", "sigmay", "Kxk")
"""Model outputs, named as in docs/model.md, section 1, Outputs (a stable interface)."""
SUPPORTED_FITTYP = (61, 62)


@dataclass(frozen=True)
class SolverOptions:
    """How the two iterative pieces of the model are solved.

    Attributes
    ----------
    re_per_point : bool
        Iterate the Re/omega fixed point per point until each has converged (default), so a
        point's result does not depend on the other points in the call; False reproduces one
        MFeval call over the vector (stops when any point has converged).
    rl_exact : bool
        Solve the MF 6.2 loaded radius to round-off (default); False stops where MFeval 4.3's
        secant stops (|dFz| <= 1e-6 FNOMIN, 18 updates).
    """

    re_per_point: bool = True
    rl_exact: bool = True

    @classmethod
    def mfeval_call(cls) -> SolverOptions:
        """The semantics of one MFeval 4.3 call over all points."""
        return cls(re_per_point=False, rl_exact=False)


def evaluate(P: Mapping[str, float], fz, kappa, alpha, gamma, vx, p=None, omega=None,
             phit=None, mode: int | UseMode = 111,
             solver: SolverOptions = SolverOptions()) -> dict[str, np.ndarray]:
    """Evaluate MF 6.1/6.2 (FITTYP from ``P``) at arrays of operating points.

    Parameters
    ----------
    P : Mapping[str, float]
        .tir parameters in SI (``TirFile.params()``); FITTYP selects 6.1 or 6.2 deflection.
    fz : array_like [N]
    kappa : array_like [-]
    alpha, gamma : array_like [rad]
    vx : array_like [m/s]
    p : array_like [Pa], optional      absent or summing to 0 -> INFLPRES
    omega : array_like [rad/s], optional  absent or summing to 0 -> estimated with Re
    phit : array_like [1/m], optional  turn slip (ignored: turn slip is off)
    mode : int or UseMode              111, 121, 211 or 221
    solver : SolverOptions             iteration semantics for Re/omega and the 6.2 Rl solve

    Returns
    -------
    dict[str, ndarray]
        One array per name in :data:`OUTPUT_COLUMNS` (ISO-W axes, SI units), plus the
        exported inputs ``kappa_out``, ``alpha_out``, ``p_used`` and ``phit_out``, and
        ``Rl_converged`` (bool; False where the MF 6.2 loaded-radius solve found no root).
    """
    fittyp = int(P["FITTYP"])
    if fittyp not in SUPPORTED_FITTYP:
        raise ValueError(f"FITTYP {fittyp} is not supported (61 or 62)")
    s = prepare(P, fz, kappa, alpha, gamma, vx, p=p, phit=phit, mode=mode)
    if omega is not None and np.sum(np.asarray(omega, dtype=float)) == 0:
        omega = None

    lon = longitudinal.fx0(P, s)
    fx = longitudinal.gx_alpha(P, s) * lon.fx0
    lat = lateral.fy0(P, s)
    lat0 = lateral.fy0(P, s, zero_camber=True)
    fy = lateral.fy_combined(P, s, lat)
    mzr = aligning.mz(P, s, lat, lat0, fy, fx, lon.kxk)
    mx = moments.mx(P, s, fy.fy)
    my = moments.my(P, s, fx)
    re, omega_used = vertical.rolling_radius(
        P, s, None if omega is None else np.broadcast_to(np.asarray(omega, float), s.fz_u.shape),
        per_point=solver.re_per_point)
    if fittyp == 62:
        dfl = vertical.deflection_62(P, s, fx, fy.fy, omega_used, exact=solver.rl_exact)
    else:
        dfl = vertical.deflection_61(P, s, fx, fy.fy, omega_used)
    a, b = vertical.contact_patch(P, s)
    st = vertical.structural(P, s, lon.kxk, lat.kya)
    muy = np.abs(lat.muy) if s.mode.limits else lat.muy
    return {
        "Fx": fx, "Fy": fy.fy, "Fz": s.fz_u, "Mx": mx, "My": my, "Mz": mzr.mz,
        "Re": re, "rho": dfl.rho, "2a": 2 * a, "t": mzr.t, "mux": lon.mux, "muy": muy,
        "omega": omega_used, "Rl": dfl.rl, "2b": 2 * b, "Mzr": mzr.mzr, "Cx": st.cx,
        "Cy": st.cy, "Cz": dfl.cz, "Kya": lat.kya, "sigmax": st.sigmax, "sigmay": st.sigmay,
        "Kxk": lon.kxk, "kappa_out": s.kappa_out, "alpha_out": s.alpha_out, "p_used": s.p,
        "phit_out": s.phit, "Rl_converged": dfl.converged,
    }


def evaluate_frame(P: Mapping[str, float], points: pd.DataFrame,
                   mode: int | UseMode = 111,
                   solver: SolverOptions = SolverOptions()) -> pd.DataFrame:
    """Evaluate on a table of operating points; return the inputs plus one column per output.

    Parameters
    ----------
    points : DataFrame
        Columns ``Fz, kappa, alpha, gamma, Vx, p`` (SI, rad), optional ``phit``, ``omega``.
    """
    out = evaluate(P, **frame_inputs(points), mode=mode, solver=solver)
    return output_frame(points, out)


def frame_inputs(points: pd.DataFrame) -> dict[str, np.ndarray | None]:
    """The model's keyword inputs from a table with columns Fz, kappa, alpha, gamma, Vx, p
    [, phit, omega]."""
    missing = [c for c in INPUT_COLUMNS if c not in points.columns]
    if missing:
        raise InputError(None, f"missing input column(s): {', '.join(missing)}")
    col = {c: points[c].to_numpy(float) for c in INPUT_COLUMNS + OPTIONAL_INPUT_COLUMNS
           if c in points.columns}
    return {"fz": col["Fz"], "kappa": col["kappa"], "alpha": col["alpha"],
            "gamma": col["gamma"], "vx": col["Vx"], "p": col["p"], "omega": col.get("omega"),
            "phit": col.get("phit")}


def output_frame(points: pd.DataFrame, out: dict[str, np.ndarray]) -> pd.DataFrame:
    """The input table followed by one column per model output (OUTPUT_COLUMNS order)."""
    # Inputs keep their names and order; outputs follow. Where an output shares an input's name
    # (Fz, omega) the column holds the model's value: Fz after the negative-load clip, omega as
    # used (given + machine eps, or estimated with Re), as MFeval's columns 3 and 19 do.
    frame = points.copy()
    for name in OUTPUT_COLUMNS:
        frame[name] = out[name]
    return frame
