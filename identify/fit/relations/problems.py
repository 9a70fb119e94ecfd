"""The pressure relations as fit problems (docs/relations.md).

Each builder turns a characteristic table (SI, identify.io.tables.characteristics schema) into a
:class:`~identify.fit.solve.problem.FitProblem` whose parameters carry the .tir key names where MF
has one (PCFY1, QSY7, PPY5, ...), so results go straight into the .tir and the discovery library
can free and test them by name. Forms that leave a coefficient out hold it fixed at its neutral
value (PCFY2 = 0 for linear load, QSY7 = 1 and QSY8 = 0 for the old rolling-resistance form).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import lmfit
import numpy as np
import pandas as pd

from identify.fit.solve.problem import Constraint, FitProblem
from identify.model import moments
from identify.model import relations as rel
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.parameters import bounds as table_bounds
from identify.model.state import prepare

CMZ_MIN_LOAD_N = 500.0
"""CMz >= 0 is enforced from this load up to twice the largest measured load, at every
pressure of the data (the thesis rejected a form that went negative below ~500 N)."""


@dataclass(frozen=True)
class Context:
    """What every relation needs besides its data.

    Attributes
    ----------
    fz0 : float [N]          nominal load (FNOMIN)
    p0_bar : float [bar]     nominal pressure (NOMPRES)
    tir : Mapping[str, float]  base .tir parameters (SI); relations read R0 and, for the
                             camber and rolling-resistance forms, the MF coefficients
    kya_from_tir : bool      the .tir's cornering stiffness was identified (trailer MF fit):
                             the relaxation strategy then uses it instead of co-fitting Kya
    """

    fz0: float
    p0_bar: float
    tir: Mapping[str, float]
    kya_from_tir: bool = False

    @property
    def r0(self) -> float:
        return float(self.tir["UNLOADED_RADIUS"])

    def dp(self, pi_bar) -> np.ndarray:
        return rel.dpi(pi_bar, self.p0_bar)


def _add(P: lmfit.Parameters, name: str, value: float, vary: bool = True,
         lo: float | None = None, hi: float | None = None) -> None:
    tlo, thi = table_bounds(name, value) if lo is None or hi is None else (lo, hi)
    lo = tlo if lo is None else lo
    hi = thi if hi is None else hi
    P.add(name, value=float(np.clip(value, lo, hi)), vary=vary, min=lo, max=hi)


def _problem(*args, **kwargs) -> FitProblem:
    """A relation's FitProblem: characteristics are measured to a relative accuracy, so the
    MCMC likelihood's noise is relative (FitProblem.noise)."""
    return FitProblem(*args, noise="relative", **kwargs)


def _select(chars: pd.DataFrame, quantity: str) -> pd.DataFrame:
    return chars[chars["quantity"] == quantity].reset_index(drop=True)


def _extra(d: pd.DataFrame, quantity: str) -> dict:
    """Per-point conditions kept with the problem for the measured-vs-model table."""
    out = {"quantity": quantity}
    for col in ("Fz_N", "gamma_deg", "Vx_mps"):
        if col in d:
            out[col] = d[col].to_numpy(float)
    return out


# ----- CFz -------------------------------------------------------------------------------------

def cfz(chars: pd.DataFrame, ctx: Context, form: str = "mf") -> FitProblem | None:
    """CFz at load: ``qfz`` form (qFz1, qFz2, qFz3) or ``mf`` form (VERTICAL_STIFFNESS, Q_FZ2,
    PFZ1; Q_FZ1 derived as in MFeval)."""
    d = _select(chars, "CFz")
    if d.empty:
        return None
    fz, dp = d["Fz_N"].to_numpy(float), ctx.dp(d["pi_bar"].to_numpy(float))
    P = lmfit.Parameters()
    c_nom = float(np.median(d["value"]))
    if form == "qfz":
        _add(P, "QFZ1", c_nom, lo=0.0, hi=10 * max(abs(c_nom), 1.0))
        _add(P, "QFZ2", 0.0, lo=-1e8, hi=1e8)
        _add(P, "QFZ3", 0.5, lo=-1.0, hi=3.0)

        def model(v):
            return rel.cfz_qfz_at_load(fz, dp, v["QFZ1"], v["QFZ2"], v["QFZ3"])
    elif form == "mf":
        _add(P, "VERTICAL_STIFFNESS", c_nom, lo=0.0, hi=10 * max(abs(c_nom), 1.0))
        # 1e-4, not 0: at Q_FZ2 = 0 MF 6.1's deflection is 0/0, rho = 0 (docs/relations.md)
        _add(P, "Q_FZ2", 1.0, lo=1e-4, hi=100.0)
        _add(P, "PFZ1", 0.5)
        r0, fz0 = ctx.r0, ctx.fz0

        def model(v):
            q1 = np.sqrt((v["VERTICAL_STIFFNESS"] * r0 / fz0) ** 2 - 4 * v["Q_FZ2"]) * fz0 / r0
            return rel.cfz_qfz_at_load(fz, dp, q1, v["Q_FZ2"] * fz0 / r0 ** 2, v["PFZ1"])
    else:
        raise ValueError(f"unknown CFz form {form!r}")
    return _problem("CFz", form, P, model, d["value"], d["pi_bar"], unit="N/m",
                      extra=_extra(d, "CFz"))


# ----- CFx, CFy --------------------------------------------------------------------------------

def _stiffness(chars, ctx, quantity, keys, form) -> FitProblem | None:
    d = _select(chars, quantity)
    if d.empty:
        return None
    nom, k1, k2, k3 = keys
    fz, dp = d["Fz_N"].to_numpy(float), ctx.dp(d["pi_bar"].to_numpy(float))
    P = lmfit.Parameters()
    _add(P, nom, float(np.median(d["value"])), lo=0.0,
         hi=10 * max(float(np.abs(d["value"]).max()), 1.0))
    _add(P, k1, 0.2)
    _add(P, k2, 0.0, vary=form == "quadratic_load")
    _add(P, k3, 0.3)
    fz0 = ctx.fz0

    def model(v):
        return rel.load_pressure_stiffness(fz, dp, v[nom], v[k1], v[k2], v[k3], fz0)
    return _problem(quantity, form, P, model, d["value"], d["pi_bar"], unit="N/m",
                      extra=_extra(d, quantity))


def cfx(chars, ctx, form="linear_load"):
    """CFx = LONGITUDINAL_STIFFNESS (1 + PCFX1 dfz + PCFX2 dfz^2)(1 + PCFX3 dpi); linear_load
    holds PCFX2 = 0. Reference load: FNOMIN (a fit at another reference load is the same
    model re-parametrised)."""
    if form not in ("linear_load", "quadratic_load"):
        raise ValueError(f"unknown CFx form {form!r}")
    return _stiffness(chars, ctx, "CFx", ("LONGITUDINAL_STIFFNESS", "PCFX1", "PCFX2", "PCFX3"),
                      form)


def cfy(chars, ctx, form="linear_load", *, cofit_kya: bool | None = None,
        pcfy2_nonpositive: bool = True) -> FitProblem | None:
    """CFy from locked-hub data (linear_load, quadratic_load) or by the relaxation strategy
    (``relaxation``: CFy coefficients chosen so that |Kya|/CFy matches sigma_y; Kya from the
    base .tir, or co-fitted PKY1, PKY2, PPY1, PPY2 with LATERAL_STIFFNESS then held at the
    base value, since only the ratio is identifiable)."""
    if form in ("linear_load", "quadratic_load"):
        return _stiffness(chars, ctx, "CFy", ("LATERAL_STIFFNESS", "PCFY1", "PCFY2", "PCFY3"),
                          form)
    if form != "relaxation":
        raise ValueError(f"unknown CFy form {form!r}")
    d = _select(chars, "sigma_y")
    if d.empty:
        return None
    fz, dp = d["Fz_N"].to_numpy(float), ctx.dp(d["pi_bar"].to_numpy(float))
    t = ctx.tir
    if cofit_kya is None:
        cofit_kya = not ctx.kya_from_tir
    P = lmfit.Parameters()
    locked = _select(chars, "CFy")
    c_nom = float(np.median(locked["value"])) if not locked.empty else float(
        t["LATERAL_STIFFNESS"])
    _add(P, "LATERAL_STIFFNESS", c_nom, vary=not cofit_kya, lo=0.0,
         hi=10 * max(abs(c_nom), 1.0))
    _add(P, "PCFY1", 0.2)
    _add(P, "PCFY2", 0.0, lo=-0.6, hi=0.6)
    _add(P, "PCFY3", 0.3)
    _add(P, "PKY1", float(t["PKY1"]), vary=cofit_kya)
    _add(P, "PKY2", float(t["PKY2"]), vary=cofit_kya, lo=0.5, hi=3.0 if cofit_kya else None)
    _add(P, "PPY1", float(t["PPY1"]), vary=cofit_kya)
    _add(P, "PPY2", float(t["PPY2"]), vary=cofit_kya)
    fz0, pky4 = ctx.fz0, float(t.get("PKY4", 2.0))

    def model(v):
        k = rel.kya(fz, dp, v["PKY1"], v["PKY2"], v["PPY1"], v["PPY2"], fz0, pky4)
        c = rel.load_pressure_stiffness(fz, dp, v["LATERAL_STIFFNESS"], v["PCFY1"],
                                        v["PCFY2"], v["PCFY3"], fz0)
        return np.abs(k) / c
    cons = (Constraint("PCFY2 <= 0", lambda v: np.array([-v["PCFY2"]])),) \
        if pcfy2_nonpositive else ()
    return _problem("CFy", "relaxation", P, model, d["value"], d["pi_bar"], unit="m",
                      constraints=cons, extra=_extra(d, "sigma_y"))


# ----- CMz -------------------------------------------------------------------------------------

def cmz(chars, ctx, form="T1", *, nonnegative: bool = True) -> FitProblem | None:
    """Yaw stiffness CMz: T1 = YAW_STIFFNESS (1 + PCMZ1 dpi) Fz/Fz0; T2 = YAW_STIFFNESS
    (PCMZ1' Fz/Fz0 + PCMZ2 (Fz/Fz0)^2)(1 + PCMZ3 dpi) with the constraint CMz >= 0 from
    CMZ_MIN_LOAD_N to twice the largest load at every measured pressure."""
    d = _select(chars, "CMz")
    if d.empty:
        return None
    fz, pi = d["Fz_N"].to_numpy(float), d["pi_bar"].to_numpy(float)
    dp = ctx.dp(pi)
    fz0 = ctx.fz0
    P = lmfit.Parameters()
    slope = float(np.median(d["value"] / (fz / fz0)))
    _add(P, "YAW_STIFFNESS", slope, lo=0.0, hi=20 * abs(slope) + 1.0)
    if form == "T1":
        _add(P, "PCMZ1", -0.3)

        def model(v):
            return rel.cmz_t1(fz, dp, v["YAW_STIFFNESS"], v["PCMZ1"], fz0)
        return _problem("CMz", "T1", P, model, d["value"], pi, unit="N*m/rad",
                          extra=_extra(d, "CMz"))
    if form != "T2":
        raise ValueError(f"unknown CMz form {form!r}")
    # T2: YAW_STIFFNESS scales (PCMZ1 r + PCMZ2 r^2); fix the scale so the shape is identifiable
    P["YAW_STIFFNESS"].set(vary=False)
    _add(P, "PCMZ1", 1.0, lo=-5.0, hi=5.0)
    _add(P, "PCMZ2", 0.0, lo=-5.0, hi=5.0)
    _add(P, "PCMZ3", -0.3)
    grid_fz = np.linspace(CMZ_MIN_LOAD_N, 2 * fz.max(), 12)
    grid_dp = ctx.dp(np.unique(pi))
    gf, gd = np.meshgrid(grid_fz, grid_dp)

    def model(v):
        return rel.cmz_t2(fz, dp, v["YAW_STIFFNESS"], v["PCMZ1"], v["PCMZ2"], v["PCMZ3"], fz0)

    def positive(v):
        return rel.cmz_t2(gf, gd, v["YAW_STIFFNESS"], v["PCMZ1"], v["PCMZ2"], v["PCMZ3"],
                          fz0).ravel() / max(abs(v["YAW_STIFFNESS"]), 1.0)
    cons = (Constraint(f"CMz >= 0 for Fz in [{CMZ_MIN_LOAD_N:g}, {2 * fz.max():g}] N",
                       positive),) if nonnegative else ()
    return _problem("CMz", "T2", P, model, d["value"], pi, unit="N*m/rad", constraints=cons,
                      extra=_extra(d, "CMz"))


# ----- rolling resistance ----------------------------------------------------------------------

def rolling_resistance(chars, ctx, form="new") -> FitProblem | None:
    """Fx,RR = My/R0 from the MF rolling-resistance moment at free rolling (kappa = alpha =
    gamma = 0): ``new`` frees QSY7, QSY8; ``old`` holds QSY7 = 1, QSY8 = 0. QSY1 is always
    fitted, QSY3 with two or more speeds, QSY4 with three or more."""
    d = _select(chars, "FxRR")
    if d.empty:
        return None
    if form not in ("new", "old"):
        raise ValueError(f"unknown rolling-resistance form {form!r}")
    fz = d["Fz_N"].to_numpy(float)
    p = d["p_Pa"].to_numpy(float) if "p_Pa" in d else d["pi_bar"].to_numpy(float) * 1e5
    vx = d["Vx_mps"].to_numpy(float) if "Vx_mps" in d else np.full(len(d), 16.7)
    speeds = np.unique(np.round(vx, 6)).size
    t = dict(ctx.tir)
    P = lmfit.Parameters()
    _add(P, "QSY1", max(float(t["QSY1"]), 1e-3))
    _add(P, "QSY3", float(t["QSY3"]), vary=speeds >= 2, lo=-0.1, hi=0.1)
    _add(P, "QSY4", float(t["QSY4"]), vary=speeds >= 3, lo=-0.1, hi=0.1)
    _add(P, "QSY7", float(t["QSY7"]) if form == "new" else 1.0, vary=form == "new",
         lo=0.5 if form == "new" else 0.0, hi=1.0 if form == "new" else 2.0)
    _add(P, "QSY8", float(t["QSY8"]) if form == "new" else 0.0, vary=form == "new",
         lo=-1.0, hi=0.0 if form == "new" else 1.0)
    zeros = np.zeros_like(fz)
    # Fx at free rolling does not depend on the QSY coefficients: evaluate it once
    state = prepare(t, fz, zeros, zeros, zeros, vx, p=p, mode=111)
    fx = evaluate(t, fz, zeros, zeros, zeros, vx, p=p, mode=111)["Fx"]
    r0 = float(t["UNLOADED_RADIUS"])

    def model(v):
        return moments.my({**t, **v}, state, fx) / r0
    return _problem("RR", form, P, model, d["value"], d["pi_bar"], unit="N",
                      extra=_extra(d, "FxRR"))


# ----- camber ----------------------------------------------------------------------------------

def _evaluate_walkers(P: Mapping, output: str, fz, kappa, alpha, gamma, vx, p,
                      mode: int) -> np.ndarray:
    """One output of the forward model at the points, for scalar parameters (-> (points,)) or
    for MCMC walkers (array values of shape (walkers, 1) -> (walkers, points)).

    The forward model is elementwise in the points and accepts a per-point array for any
    parameter, so W walkers are one call on the points tiled W times, each tile carrying its
    walker's values: no Python loop over walkers or points.
    """
    arrays = {k: np.asarray(v, dtype=float) for k, v in P.items()
              if not isinstance(v, str) and np.ndim(v) > 0}
    if not arrays:
        return evaluate(P, fz, kappa, alpha, gamma, vx, p=p, mode=mode)[output]
    w = max(a.shape[0] for a in arrays.values())
    n = np.size(fz)
    per_point = {k: np.repeat(np.broadcast_to(a.reshape(a.shape[0]), (w,)), n)
                 for k, a in arrays.items()}
    tiled = [np.tile(np.asarray(x, dtype=float), w) for x in (fz, kappa, alpha, gamma, vx, p)]
    out = evaluate({**P, **per_point}, *tiled[:5], p=tiled[5], mode=mode)[output]
    return out.reshape(w, n)


CAMBER_TERMS = {"Fy_gamma": ("Fy", "PPY5"), "Mz_gamma": ("Mz", "PPZ2"),
                "Mx_gamma": ("Mx", "PPMX1")}


def camber(chars, ctx, quantity: str, *, vx: float = 0.05,
           max_gamma_deg: float | None = None) -> FitProblem | None:
    """Camber thrust or torque (camber run minus the 0-degree reference) through the MF
    equations at alpha = kappa = 0: Fy_gamma frees PPY5, Mz_gamma PPZ2, Mx_gamma PPMX1, with the
    rest of the .tir fixed (fit Fy_gamma first: PPY5 also moves Mz)."""
    d = _select(chars, quantity)
    if max_gamma_deg is not None and not d.empty:
        d = d[np.abs(d["gamma_deg"]) <= max_gamma_deg].reset_index(drop=True)
    if d.empty:
        return None
    output, key = CAMBER_TERMS[quantity]
    fz = d["Fz_N"].to_numpy(float)
    p = d["pi_bar"].to_numpy(float) * 1e5
    g = np.deg2rad(d["gamma_deg"].to_numpy(float))
    n = fz.size
    t = dict(ctx.tir)
    P = lmfit.Parameters()
    _add(P, key, float(t.get(key, 0.0)))
    zeros = np.zeros(2 * n)
    fz2, p2 = np.concatenate([fz, fz]), np.concatenate([p, p])
    g2 = np.concatenate([g, np.zeros(n)])
    v2 = np.full(2 * n, vx)

    def model(v):
        out = _evaluate_walkers({**t, **v}, output, fz2, zeros, zeros, g2, v2, p2, FIT_MODE)
        return out[..., :n] - out[..., n:]
    return _problem("camber", quantity, P, model, d["value"], d["pi_bar"],
                      unit="N" if output == "Fy" else "N*m", extra=_extra(d, quantity))


# ----- sidewall stiffness from eigenfrequencies -----------------------------------------------

def sidewall(chars, ctx, mode: str, form: str = "scaling") -> FitProblem | None:
    """Eigenfrequency of one rigid-ring mode vs pressure: ``scaling`` f = f0 sqrt(1 + F dpi)
    (c_b = c_b0 (1 + F dpi)) with F_<MODE> in the .tir's MFID_EXTENSIONS; ``rotta`` f =
    f0 sqrt(c_rotta(p)/c_rotta(p0)) with the ring data of docs/relations.md (one scale)."""
    d = _select(chars, "f_nat")
    d = d[d["mode"] == mode].reset_index(drop=True) if not d.empty else d
    if d.empty or d["pi_bar"].nunique() < 2:
        return None
    pi = d["pi_bar"].to_numpy(float)
    dp = ctx.dp(pi)
    key = f"F_{mode.upper()}"
    P = lmfit.Parameters()
    f_nom = float(np.median(d["value"]))
    _add(P, f"F0_{mode.upper()}", f_nom, lo=0.0, hi=10 * max(abs(f_nom), 1.0))
    if form == "scaling":
        _add(P, key, 0.5, lo=-0.99, hi=5.0)

        def model(v):
            return v[f"F0_{mode.upper()}"] * np.sqrt(1 + v[key] * dp)
    elif form == "rotta":
        ring = rel.rotta_ring(pi * 1e5, 0.300, 1.6e6, 0.010, 0.121, np.deg2rad(62.3))[mode]
        ring0 = rel.rotta_ring(ctx.p0_bar * 1e5, 0.300, 1.6e6, 0.010, 0.121,
                               np.deg2rad(62.3))[mode]

        def model(v):
            return v[f"F0_{mode.upper()}"] * np.sqrt(ring / ring0)
    else:
        raise ValueError(f"unknown sidewall form {form!r}")
    return _problem("sidewall", f"{form}_{mode}", P, model, d["value"], pi, unit="Hz",
                      extra=_extra(d, "f_nat"))

