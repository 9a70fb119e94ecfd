"""Pre-processing of operating points (docs/model.md, sections 1-3).

Turns raw input arrays into an :class:`OperatingState`: the unmodified ("_u") copies, the limited
values the force equations use, the low-speed weights and the basic normalised variables.
Pure functions, no I/O.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.model.modes import UseMode

EPS = 1e-6
"""MFeval's epsilon in denominators (docs/model.md, section 1, Notation)."""


def sgn1(x: np.ndarray, xp=np) -> np.ndarray:
    """Sign with sgn1(0) = +1 (MFeval's 'epsilon with the sign of its neighbour')."""
    return xp.where(x < 0, -1.0, 1.0)


@dataclass(frozen=True)
class OperatingState:
    """Operating points after MFeval's pre-processing. All arrays have one shape.

    Attributes
    ----------
    fz_u, kappa_u, alpha_u, gamma_u, vx_u : ndarray
        Unmodified inputs [N, -, rad, rad, m/s] (fz_u after the negative-load clip).
    fz, kappa, alpha, gamma, p : ndarray
        Limited values [N, -, rad, rad, Pa] (equal to the inputs without limit checks).
    fz_low : ndarray
        max(Fz, FZMIN) with limit checks, else Fz [N].
    phit : ndarray
        Turn slip after the empirical modifications [1/m] (exported only).
    ws : ndarray
        Smooth low-speed factor (1 above VXLOW or without limit checks) [-].
    kappa_out, alpha_out : ndarray
        Exported kappa (kappa_u * w_lin at low speed) and alpha (0 where Vx = 0).
    alpha_star, gamma_star : ndarray
        alpha* and gamma* of the useMode tens digit [rad].
    dfz, dpi : ndarray
        Normalised load and pressure increments [-].
    fz0p : float
        LFZO * FNOMIN [N].
    cos_alpha_p : ndarray
        cos(alpha') = Vcx / Vc' [-].
    mode : UseMode
    """

    fz_u: np.ndarray
    kappa_u: np.ndarray
    alpha_u: np.ndarray
    gamma_u: np.ndarray
    vx_u: np.ndarray
    fz: np.ndarray
    kappa: np.ndarray
    alpha: np.ndarray
    gamma: np.ndarray
    p: np.ndarray
    fz_low: np.ndarray
    phit: np.ndarray
    ws: np.ndarray
    kappa_out: np.ndarray
    alpha_out: np.ndarray
    alpha_star: np.ndarray
    gamma_star: np.ndarray
    dfz: np.ndarray
    dpi: np.ndarray
    fz0p: float
    cos_alpha_p: np.ndarray
    mode: UseMode


def _column(x, n: int) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    return np.broadcast_to(a, (n,)).copy() if a.ndim == 0 else a.astype(float, copy=True)


def prepare(P: Mapping[str, float], fz, kappa, alpha, gamma, vx, p=None, phit=None,
            mode: UseMode | int = 111) -> OperatingState:
    """Apply the MFeval pre-processing to arrays of operating points.

    Parameters
    ----------
    P : Mapping[str, float]
        .tir parameters (SI).
    fz : array_like [N]
        Vertical load; negative values are replaced by 0.
    kappa : array_like [-]
        Longitudinal slip.
    alpha, gamma : array_like [rad]
        Side-slip and inclination angles.
    vx : array_like [m/s]
        Forward speed of the contact centre.
    p : array_like [Pa], optional
        Inflation pressure; absent or summing to 0 means INFLPRES everywhere.
    phit : array_like [1/m], optional
        Turn slip (only exported; turn slip is off).
    mode : UseMode or int
        MFeval useMode.

    Returns
    -------
    OperatingState
    """
    mode = mode if isinstance(mode, UseMode) else UseMode.from_code(mode)
    fz_u = np.atleast_1d(np.asarray(fz, dtype=float)).ravel()
    n = fz_u.size
    fz_u = np.maximum(fz_u, 0.0) if n else fz_u
    # keep NaN loads as NaN (np.maximum propagates them) so bad inputs stay visible
    kappa_u = _column(kappa, n)
    alpha_u = _column(alpha, n)
    gamma_u = _column(gamma, n)
    vx_u = _column(vx, n)
    if p is None or np.sum(np.asarray(p, dtype=float)) == 0:
        p_in = np.full(n, float(P["INFLPRES"]))
    else:
        p_in = _column(p, n)
    phit_v = np.zeros(n) if phit is None else _column(phit, n)

    fz_l = fz_u.copy()
    kappa_l = kappa_u.copy()
    alpha_l = alpha_u.copy()
    gamma_l = gamma_u.copy()
    ws = np.ones(n)
    kappa_out = kappa_u.copy()
    if mode.limits:
        vxlow = float(P["VXLOW"])
        phit_v = phit_v * np.cos(alpha_u)
        low = np.abs(vx_u) <= vxlow
        w_lin = np.where(low, np.abs(vx_u) / vxlow, 1.0)
        ws = np.where(low, 1.0 - 0.5 * (1.0 + np.cos(np.pi * vx_u / vxlow)), 1.0)
        phit_v = phit_v * w_lin
        kappa_out = kappa_u * w_lin
        phit_v = np.where(vx_u < 0, -phit_v, phit_v)
        speed = np.abs(vx_u) + np.abs(np.tan(alpha_u) * vx_u)
        kappa_l = kappa_l * w_lin
        alpha_l = np.where(speed < vxlow, alpha_l * speed / vxlow, alpha_l)
        alpha_l = np.clip(alpha_l, P["ALPMIN"], P["ALPMAX"])
        gamma_l = np.clip(gamma_l, P["CAMMIN"], P["CAMMAX"])
        fz_l = np.minimum(fz_l, P["FZMAX"])
        fz_low = np.maximum(fz_l, P["FZMIN"])
        p_l = np.clip(p_in, P["PRESMIN"], P["PRESMAX"])
        kappa_l = np.clip(kappa_l, P["KPUMIN"], P["KPUMAX"])
    else:
        fz_low = fz_l
        p_l = p_in
    alpha_out = np.where(vx_u == 0, 0.0, alpha_u)

    fz0p = float(P["LFZO"]) * float(P["FNOMIN"])
    dfz = (fz_l - fz0p) / fz0p
    dpi = (p_l - P["NOMPRES"]) / P["NOMPRES"]
    if mode.alpha_star:
        alpha_star = np.tan(alpha_l) * np.sign(vx_u)
        gamma_star = np.sin(gamma_l)
    else:
        alpha_star = alpha_l
        gamma_star = gamma_l
    vcy = np.tan(alpha_l) * np.abs(vx_u)
    vc = np.sqrt(vx_u ** 2 + vcy ** 2)
    cos_alpha_p = vx_u / (vc + EPS * sgn1(vc))
    return OperatingState(
        fz_u=fz_u, kappa_u=kappa_u, alpha_u=alpha_u, gamma_u=gamma_u, vx_u=vx_u,
        fz=fz_l, kappa=kappa_l, alpha=alpha_l, gamma=gamma_l, p=p_l, fz_low=fz_low,
        phit=phit_v, ws=ws, kappa_out=kappa_out, alpha_out=alpha_out,
        alpha_star=alpha_star, gamma_star=gamma_star, dfz=dfz, dpi=dpi, fz0p=fz0p,
        cos_alpha_p=cos_alpha_p, mode=mode)
