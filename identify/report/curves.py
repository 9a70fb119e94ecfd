"""Model curves for the report, computed from the fit directory alone.

Relation fits: the relation is rebuilt from the fit plan (``identify.fit.plan``) with the
fitted parameters of fit.json and evaluated on a dense grid. The rebuild is first checked
against the model values recorded in measured_vs_model.csv; when it does not reproduce them
(or cannot be built), the curves join the recorded model values at the measured points
instead, and say so.

MF slip curves: the written .tir evaluated with ``identify.model.evaluate`` over the slip,
camber and load ranges of the MF rows of measured_vs_model.csv.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import pandas as pd

from identify.report.tables import num

N_DENSE = 60
MF_MODE = 211
"""useMode of the MF slip curves (limit checks off, alpha* = alpha), as the fits use."""

#: x-axis column of each relation quantity (everything else is plotted against load)
X_OF_QUANTITY = {"Fy_gamma": "gamma_deg", "Mz_gamma": "gamma_deg", "Mx_gamma": "gamma_deg",
                 "f_nat": "pi_bar"}
X_LABEL = {"Fz_N": "vertical load Fz [N]", "gamma_deg": "camber angle [deg]",
           "pi_bar": "inflation pressure [bar]", "alpha_deg": "slip angle [deg]",
           "kappa": "longitudinal slip kappa [-]", "Vx_mps": "speed [m/s]"}
CONDITIONS = ("Fz_N", "gamma_deg", "Vx_mps")


@dataclass(frozen=True)
class Curve:
    """One model line: pressure [bar], the other conditions it holds, x and y."""

    pi_bar: float
    group: tuple            # (("Fz_N", 5000.0), ...) the secondary conditions held fixed
    x: np.ndarray
    y: np.ndarray


@dataclass(frozen=True)
class RelationCurves:
    x_column: str
    curves: tuple[Curve, ...]
    exact: bool            # dense curves of the rebuilt relation (else joined model points)
    note: str


def x_column(quantity: str) -> str:
    return X_OF_QUANTITY.get(quantity, "Fz_N")


def _levels(values: np.ndarray, tol: float) -> np.ndarray:
    """Cluster sorted values into levels closer than ``tol``; return each value's level
    (the level mean)."""
    values = np.asarray(values, dtype=float)
    out = np.full(values.shape, np.nan)
    ok = np.isfinite(values)
    if not ok.any():
        return out
    order = np.argsort(values[ok])
    v = values[ok][order]
    starts = np.r_[0, np.flatnonzero(np.diff(v) > tol) + 1]
    level = np.empty_like(v)
    for a, b in zip(starts, np.r_[starts[1:], v.size]):
        level[a:b] = v[a:b].mean()
    tmp = np.empty_like(v)
    tmp[order] = level
    out[ok] = tmp
    return out


def secondary_columns(rows: pd.DataFrame, xcol: str) -> list[str]:
    """Conditions other than x and pressure that take more than one value in the rows."""
    out = []
    for c in CONDITIONS:
        if c == xcol or c not in rows:
            continue
        v = rows[c].to_numpy(float)
        v = v[np.isfinite(v)]
        if v.size and np.unique(np.round(v, 6)).size > 1:
            out.append(c)
    return out


def group_key(rows: pd.DataFrame, cols: list[str]) -> list[tuple]:
    """Per row: the secondary condition levels as ((column, level), ...)."""
    if not cols:
        return [()] * len(rows)
    tol = {"Fz_N": 100.0, "gamma_deg": 0.25, "Vx_mps": 0.5}
    lv = {c: _levels(rows[c].to_numpy(float), tol.get(c, 1e-6)) for c in cols}
    return [tuple((c, float(np.round(lv[c][i], 6))) for c in cols) for i in range(len(rows))]


# ----- relation fits ---------------------------------------------------------------------------

def _plan_entry(relation: str, form: str):
    from identify.fit.plan import PLAN

    for e in PLAN:
        if e.relation == relation and e.form == form:
            return e
    return None


def _chars(rows: pd.DataFrame, quantity: str, form: str, value: np.ndarray) -> pd.DataFrame:
    """A characteristics table (identify.io.characteristics schema) for a rebuild."""
    n = len(rows)
    mode = form.split("_", 1)[1] if quantity == "f_nat" and "_" in form else None
    frame = pd.DataFrame({
        "run": "report", "quantity": quantity,
        "pi_bar": rows["pi_bar"].to_numpy(float),
        "Fz_N": rows["Fz_N"].to_numpy(float) if "Fz_N" in rows else np.full(n, np.nan),
        "value": np.asarray(value, dtype=float), "unit": "",
        "Vx_mps": rows["Vx_mps"].to_numpy(float) if "Vx_mps" in rows else np.full(n, np.nan),
        "gamma_deg": rows["gamma_deg"].to_numpy(float) if "gamma_deg" in rows
        else np.full(n, np.nan),
        "mode": mode})
    frame["p_Pa"] = frame["pi_bar"] * 1e5
    if frame["Vx_mps"].isna().all():
        frame = frame.drop(columns="Vx_mps")
    return frame


def _values(problem, fit: Mapping[str, Any]) -> dict:
    vals = problem.values()
    for src in ("fixed", "parameters"):
        for k, v in (fit.get(src) or {}).items():
            if v is not None:
                vals[k] = float(v)
    return vals


def _context(fd):
    from identify.fit.relations import Context

    tir = {k: float(v) for k, v in (fd.tir or {}).items()
           if isinstance(v, (int, float)) and not isinstance(v, bool)}
    ks = fd.key_sources
    return Context(fz0=fd.nominal_load_N, p0_bar=fd.nominal_pressure_bar, tir=tir,
                   kya_from_tir=any(str(ks.get(k, "")).startswith("MF/")
                                    for k in ("PKY1", "PKY2")))


def _rebuild(fd, fit, rows: pd.DataFrame, quantity: str):
    """(model function of a characteristics-like frame) or raise."""
    import warnings

    entry = _plan_entry(str(fit.get("relation")), str(fit.get("form")))
    if entry is None:
        raise LookupError("not in the fit plan")
    if fd.tir is None:
        raise LookupError("no .tir")
    ctx = _context(fd)
    fill = float(np.nanmedian(np.abs(rows["measured"].to_numpy(float)))) or 1.0

    def evaluate(frame: pd.DataFrame, value=None) -> np.ndarray:
        value = np.full(len(frame), fill) if value is None else value
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            problem = entry.build(_chars(frame, quantity, str(fit.get("form")), value), ctx)
            if problem is None:
                raise LookupError("the relation did not build on its own data")
            return np.asarray(problem.model(_values(problem, fit)), dtype=float)
    return evaluate


def relation_curves(fd, fit: Mapping[str, Any], rows: pd.DataFrame) -> RelationCurves:
    """Model curves of one relation fit, one per pressure (and per level of any other
    condition that varies)."""
    quantity = str(rows["quantity"].iloc[0]) if len(rows) else str(fit.get("relation"))
    xcol = x_column(quantity)
    sec = secondary_columns(rows, xcol)
    keys = group_key(rows, sec)
    model = rows["model"].to_numpy(float)
    note = ""
    try:
        evaluate = _rebuild(fd, fit, rows, quantity)
        again = evaluate(rows, rows["measured"].to_numpy(float))
        scale = max(float(np.nanmax(np.abs(model))) if len(model) else 1.0, 1e-300)
        if again.shape != model.shape or not np.allclose(again, model, rtol=1e-6,
                                                         atol=1e-9 * scale, equal_nan=True):
            raise ValueError("the rebuilt relation does not reproduce the recorded model "
                             "values")
        curves = _dense(rows, xcol, sec, keys, evaluate)
        return RelationCurves(xcol, tuple(curves), True, "model lines: the fitted relation "
                                                         "evaluated on a dense grid")
    except Exception as exc:  # noqa: BLE001 - any failure falls back to the recorded values
        note = (f"model lines join the model values at the measured points (relation not "
                f"re-evaluated: {exc})")
    curves = []
    for (p, key), idx in _group_indices(rows, keys).items():
        x = rows[xcol].to_numpy(float)[idx]
        order = np.argsort(x, kind="stable")
        curves.append(Curve(p, key, x[order], model[idx][order]))
    return RelationCurves(xcol, tuple(curves), False, note)


def _group_indices(rows: pd.DataFrame, keys: list[tuple]) -> dict:
    groups: dict = {}
    pis = np.round(rows["pi_bar"].to_numpy(float), 4)
    for i, (p, k) in enumerate(zip(pis, keys)):
        groups.setdefault((float(p), k), []).append(i)
    return {k: np.array(v) for k, v in sorted(groups.items(), key=lambda kv: (kv[0][0],
                                                                              kv[0][1]))}


def _dense(rows, xcol, sec, keys, evaluate) -> list[Curve]:
    x_all = rows[xcol].to_numpy(float)
    if xcol == "pi_bar":  # one curve over pressure
        grid = np.linspace(np.nanmin(x_all), np.nanmax(x_all), N_DENSE)
        frame = pd.DataFrame({"pi_bar": grid})
        for c in CONDITIONS:
            frame[c] = float(np.nanmedian(rows[c])) if c in rows and rows[c].notna().any() \
                else np.nan
        y = evaluate(frame)
        return [Curve(float("nan"), (), grid, y)]
    out = []
    for (p, key), idx in _group_indices(rows, keys).items():
        # the x range of this secondary level over all pressures: curves span the same range
        same = np.array([k == key for k in keys])
        lo, hi = np.nanmin(x_all[same]), np.nanmax(x_all[same])
        if not np.isfinite(lo) or hi <= lo:
            lo, hi = lo - 0.5 * abs(lo or 1.0), hi + 0.5 * abs(hi or 1.0)
        grid = np.linspace(lo, hi, N_DENSE)
        frame = pd.DataFrame({xcol: grid, "pi_bar": p})
        for c in CONDITIONS:
            if c == xcol:
                continue
            level = dict(key).get(c)
            if level is None:
                v = rows[c].to_numpy(float)[idx] if c in rows else np.array([np.nan])
                level = float(np.nanmedian(v)) if np.isfinite(v).any() else np.nan
            frame[c] = level
        out.append(Curve(p, key, grid, evaluate(frame)))
    return out


# ----- MF slip curves --------------------------------------------------------------------------

@dataclass(frozen=True)
class SlipPanel:
    """One pressure's panel of an MF slip page: model curves and measured points per load."""

    pi_bar: float
    loads: tuple[float, ...]
    curves: tuple[tuple[np.ndarray, np.ndarray], ...]     # per load (x, y); the ellipse:
    #                                         per load, sign of alpha and slip angle (Fx, Fy)
    points: tuple[tuple[np.ndarray, np.ndarray], ...]     # per load (x, y), may be empty


@dataclass(frozen=True)
class SlipPage:
    title: str
    xlabel: str
    ylabel: str
    panels: tuple[SlipPanel, ...]
    note: str = ""
    ellipse: bool = False
    alphas_deg: tuple[float, ...] = ()


PURE_KAPPA = 0.005
PURE_ALPHA = np.deg2rad(0.5)
PURE_GAMMA_DEG = 0.5


def _mf_levels(mf: pd.DataFrame, fnomin: float):
    pis = np.round(mf["pi_bar"].to_numpy(float), 2)
    tol = 0.05 * (fnomin if math.isfinite(fnomin) and fnomin > 0 else 4000.0)
    loads = _levels(mf["Fz_N"].to_numpy(float), tol)
    return pis, loads


def _pick_loads(levels: np.ndarray, limit: int = 5) -> list[float]:
    u = np.unique(levels[np.isfinite(levels)])
    if u.size <= limit:
        return [float(v) for v in u]
    idx = np.unique(np.round(np.linspace(0, u.size - 1, limit)).astype(int))
    return [float(u[i]) for i in idx]


def mf_slip_pages(fd) -> tuple[list[SlipPage], list[str]]:
    """The MF slip pages (Fy-alpha, Fx-kappa, Mz-alpha, Mx-gamma, friction ellipse) and notes
    on pages left out. Empty when the fit has no MF rows or no readable .tir."""
    from identify.model.evaluate import evaluate

    mf = fd.mf_rows()
    notes: list[str] = []
    if mf.empty:
        return [], notes
    if fd.tir is None:
        return [], ["MF slip pages left out: the .tir could not be read"]
    P = dict(fd.tir)
    fnomin = num(P.get("FNOMIN", fd.nominal_load_N))
    pis, loads = _mf_levels(mf, fnomin)
    q = mf["quantity"].astype(str).to_numpy()
    alpha = mf["alpha_rad"].to_numpy(float)
    kappa = mf["kappa"].to_numpy(float)
    gamma = mf["gamma_deg"].to_numpy(float)
    vx_all = mf["Vx_mps"].to_numpy(float)
    vx = float(np.nanmedian(vx_all)) if np.isfinite(vx_all).any() else 16.7
    pressures = sorted(set(float(p) for p in pis[np.isfinite(pis)]))
    load_levels = _pick_loads(loads)

    def rng(values, sel, default):
        v = values[sel & np.isfinite(values)]
        if v.size < 2 or np.ptp(v) <= 0:
            return default
        return float(v.min()), float(v.max())

    def model(p_bar, fz, k, a, g_deg, out):
        n = np.size(k) if np.ndim(k) else np.size(a) if np.ndim(a) else np.size(g_deg)
        arr = (lambda v: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy())
        with np.errstate(all="ignore"):
            res = evaluate(P, arr(fz), arr(k), arr(a), np.deg2rad(arr(g_deg)), arr(vx),
                           p=arr(p_bar * 1e5), mode=MF_MODE)
        return {o: np.asarray(res[o], dtype=float) for o in out}

    def page(title, quantity, xname, xlabel, ylabel, xrange, pure, to_x):
        sel_q = q == quantity
        panels = []
        for p in pressures:
            curves, points = [], []
            for fz in load_levels:
                grid = np.linspace(*xrange, N_DENSE)
                kw = {"k": 0.0, "a": 0.0, "g_deg": 0.0}
                kw[xname] = grid
                y = model(p, fz, kw["k"], kw["a"], kw["g_deg"], (quantity,))[quantity]
                curves.append((to_x(grid), y))
                sel = sel_q & (pis == round(p, 2)) & (loads == fz) & pure
                meas = mf["measured"].to_numpy(float)[sel]
                xs = {"k": kappa, "a": alpha, "g_deg": gamma}[xname][sel]
                points.append((to_x(xs), meas))
            panels.append(SlipPanel(p, tuple(load_levels), tuple(curves), tuple(points)))
        return SlipPage(title, xlabel, ylabel, tuple(panels))

    small_k = np.nan_to_num(np.abs(kappa), nan=0.0) <= PURE_KAPPA
    small_a = np.nan_to_num(np.abs(alpha), nan=0.0) <= PURE_ALPHA
    small_g = np.nan_to_num(np.abs(gamma), nan=0.0) <= PURE_GAMMA_DEG
    pages = []
    a_rng = rng(alpha, np.isin(q, ("Fy", "Mz")), None)
    k_rng = rng(kappa, q == "Fx", None)
    g_rng = rng(gamma, np.ones(q.size, bool), None)
    if a_rng is not None:
        pages.append(page("Fy - alpha (pure side slip, kappa = 0, gamma = 0)", "Fy", "a",
                          "slip angle [deg]", "Fy [N]", a_rng, small_k & small_g, np.rad2deg))
    else:
        notes.append("Fy-alpha and Mz-alpha pages left out: the MF rows hold no slip-angle "
                     "range")
    if k_rng is not None:
        pages.append(page("Fx - kappa (pure longitudinal slip, alpha = 0, gamma = 0)", "Fx",
                          "k", "longitudinal slip kappa [-]", "Fx [N]", k_rng,
                          small_a & small_g, lambda v: v))
    else:
        notes.append("Fx-kappa page left out: the MF rows hold no longitudinal-slip range")
    if a_rng is not None:
        pages.append(page("Mz - alpha (pure side slip, kappa = 0, gamma = 0)", "Mz", "a",
                          "slip angle [deg]", "Mz [N m]", a_rng, small_k & small_g,
                          np.rad2deg))
    if g_rng is not None and g_rng[1] - g_rng[0] >= 2 * PURE_GAMMA_DEG:
        pages.append(page("Mx - gamma (alpha = 0, kappa = 0)", "Mx", "g_deg",
                          "camber angle [deg]", "Mx [N m]", g_rng, small_k & small_a,
                          lambda v: v))
    else:
        notes.append("Mx-gamma page left out: the MF rows hold no camber range")
    if a_rng is not None and k_rng is not None:
        amax = max(abs(a_rng[0]), abs(a_rng[1]))
        alphas = tuple(float(np.rad2deg(a)) for a in (amax / 3, 2 * amax / 3, amax))
        panels = []
        for p in pressures:
            curves = []
            for fz in load_levels:
                for sign in (1.0, -1.0):
                    for a_deg in alphas:
                        grid = np.linspace(*k_rng, N_DENSE)
                        r = model(p, fz, grid, np.deg2rad(sign * a_deg), 0.0, ("Fx", "Fy"))
                        curves.append((r["Fx"], r["Fy"]))
            panels.append(SlipPanel(p, tuple(load_levels), tuple(curves), ()))
        pages.append(SlipPage("Friction ellipse (combined slip: Fy vs Fx, kappa swept at "
                              "fixed slip angles)", "Fx [N]", "Fy [N]", tuple(panels),
                              ellipse=True, alphas_deg=alphas))
    return pages, notes
