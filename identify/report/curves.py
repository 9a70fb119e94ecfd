"""Model curves of the relation fits for the report, computed from the fit directory alone.

The relation is rebuilt from the fit plan (``identify.fit.relations.plan``) with the
fitted parameters of fit.json and evaluated on a dense grid. The rebuild is first checked
against the model values recorded in measured_vs_model.csv; when it does not reproduce them
(or cannot be built), the curves join the recorded model values at the measured points
instead, and say so. The grouping helpers (condition levels, secondary conditions) serve the
MF stage pages and slip pages too.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from identify.core.levels import gap_levels
from identify.fit.relations.plan import PLAN
from identify.fit.relations.problems import Context
from identify.fit.result import FitResult
from identify.io.fitdir import FitDir

N_DENSE = 60
"""Points of a dense model curve."""

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


def levels(values: np.ndarray, tol: float) -> np.ndarray:
    """Cluster sorted values into levels closer than ``tol``; return each value's level
    (the level mean: identify.core.levels.gap_levels)."""
    return gap_levels(values, tol)


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
    tol = {"Fz_N": 100.0, "gamma_deg": 0.25, "Vx_mps": 0.5, "alpha_rad": np.deg2rad(0.5),
           "kappa": 0.02}
    lv = {c: levels(rows[c].to_numpy(float), tol.get(c, 1e-6)) for c in cols}
    return [tuple((c, float(np.round(lv[c][i], 6))) for c in cols) for i in range(len(rows))]


# ----- relation fits ---------------------------------------------------------------------------

def _plan_entry(relation: str, form: str):
    for e in PLAN:
        if e.relation == relation and e.form == form:
            return e
    return None


def _chars(rows: pd.DataFrame, quantity: str, form: str, value: np.ndarray) -> pd.DataFrame:
    """A characteristics table (identify.io.tables.characteristics schema) for a rebuild."""
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


def _values(problem, fit: FitResult) -> dict:
    """The problem's values with every recorded parameter of the fit (fixed and free; one
    that fit.json could not hold, NaN, keeps the problem's value)."""
    vals = problem.values()
    vals.update({k: float(v) for k, v in fit.parameters.items() if not math.isnan(v)})
    return vals


def _context(fd: FitDir) -> Context:
    tir = {k: float(v) for k, v in (fd.tir or {}).items()
           if isinstance(v, (int, float)) and not isinstance(v, bool)}
    ks = fd.key_sources
    return Context(fz0=fd.nominal_load_N, p0_bar=fd.nominal_pressure_bar, tir=tir,
                   kya_from_tir=any(k in ks and ks[k].supplied_by.startswith("MF/")
                                    for k in ("PKY1", "PKY2")))


def _rebuild(fd: FitDir, fit: FitResult, rows: pd.DataFrame, quantity: str):
    """(model function of a characteristics-like frame) or raise."""
    entry = _plan_entry(fit.relation, fit.form)
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
            problem = entry.build(_chars(frame, quantity, fit.form, value), ctx)
            if problem is None:
                raise LookupError("the relation did not build on its own data")
            return np.asarray(problem.model(_values(problem, fit)), dtype=float)
    return evaluate


def relation_curves(fd: FitDir, fit: FitResult, rows: pd.DataFrame) -> RelationCurves:
    """Model curves of one relation fit, one per pressure (and per level of any other
    condition that varies)."""
    quantity = str(rows["quantity"].iloc[0]) if len(rows) else fit.relation
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


# ----- sweeps ------------------------------------------------------------------------------------

SWEEP_MIN_POINTS = 8
"""Fewest points of one sweep at a fixed operating point for it to count as a sweep."""


def sweep_rows(rows: pd.DataFrame, fixed: str, varying: str, spread: float,
               resolution: float) -> np.ndarray:
    """Rows of sweeps in ``varying`` at a fixed ``fixed`` (e.g. camber sweeps at a fixed slip
    angle): rows that share pressure, load level, quantity and ``fixed`` (to ``resolution``)
    with rows of at least :data:`SWEEP_MIN_POINTS` distinct values of ``varying`` (to a tenth
    of ``spread``) spanning more than ``spread``. Plotted against ``fixed`` they would be
    vertical bars. A point of another sweep at the same operating point goes with them."""
    n = len(rows)
    if n == 0 or fixed not in rows or varying not in rows:
        return np.zeros(n, bool)
    f = rows[fixed].to_numpy(float)
    v = rows[varying].to_numpy(float)
    fz = levels(rows["Fz_N"].to_numpy(float), 100.0) if "Fz_N" in rows else np.zeros(n)
    key = pd.DataFrame({"q": rows["quantity"].astype(str).to_numpy() if "quantity" in rows
                        else "", "p": np.round(rows["pi_bar"].to_numpy(float), 4),
                        "fz": np.round(fz, 3), "f": np.round(f / resolution)})
    key["v"] = v
    key["vr"] = np.round(v / (spread / 10.0))
    groups = key.groupby(["q", "p", "fz", "f"], dropna=False)
    g = groups["v"]
    distinct = groups["vr"].transform("nunique").to_numpy()
    span = np.nan_to_num((g.transform("max") - g.transform("min")).to_numpy(float))
    return (distinct >= SWEEP_MIN_POINTS) & (span > spread) & np.isfinite(f)


def camber_sweeps(rows: pd.DataFrame) -> np.ndarray:
    """Rows of camber sweeps at a fixed slip angle (vertical bars against slip angle)."""
    return sweep_rows(rows, "alpha_rad", "gamma_deg", 1.0, np.deg2rad(0.05))


def slip_sweeps(rows: pd.DataFrame) -> np.ndarray:
    """Rows of slip-angle sweeps at a fixed camber (vertical bars against camber)."""
    return sweep_rows(rows, "gamma_deg", "alpha_rad", np.deg2rad(1.0), 0.05)
