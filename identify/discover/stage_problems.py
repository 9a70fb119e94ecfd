"""Magic Formula stage problems on trailer sweeps, for discovery.

Small, self-contained :class:`~identify.fit.solve.problem.FitProblem` builders on the forward
model's
pieces (``fx0``, ``fy0``, ``mx``, ``mz``): one output, the sweeps that excite it, a set of free
MF coefficients, and every other key taken from a base .tir. The model reads the whole .tir
(``{**tir, **values}``), so any .tir key can be added as a parameter (a library candidate held at
its neutral value). The operating-point pre-processing is done once per problem.

The trailer table (``identify.io.trailer.files`` columns ``Fz, kappa, alpha, gamma, Vx, p`` and the
measured ``Fx, Fy, Mx, My, Mz``) gets a ``sweep`` id, a ``kind`` (cornering, braking_driving,
combined, camber, rolling_resistance) and a ``shape`` (what the sweep varies: ``alpha``,
``kappa``, ``gamma``, ``alpha@gamma``, ``kappa@alpha``, ``speed``) by :func:`label_sweeps`.
Each shape is one characteristic of the thesis metric: the error of a stage problem is the
mean over (pressure, shape) groups (``extra["metric_group"]``), so that the small camber
thrust of a pure camber sweep is not drowned by the cornering force.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

import lmfit
import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from identify.discover.design import levels
from identify.discover.drift import session_positions
from identify.fit.mf.pressure_holdout import is_pressure_coefficient
from identify.fit.mf.stage_specs import STAGES
from identify.fit.solve.problem import FitProblem
from identify.model import aligning, lateral, longitudinal, moments
from identify.model.modes import TRAILER_MODE
from identify.model.parameters import bounds as table_bounds
from identify.model.state import prepare

__all__ = ["DiscoveryStage", "DISCOVERY_STAGES", "label_sweeps", "stage_problem", "add_parameter",
           "sweep_shapes", "covering"]

_TINY = 1e-6


@dataclass(frozen=True)
class DiscoveryStage:
    """The discovery problem of one measured output: which sweeps, which coefficients.

    The coefficients are those of one MF fitting stage (``fit_stage``, a key of
    :data:`identify.fit.mf.stage_specs.STAGES`, the one table of the stages' coefficients):
    ``free`` is the subset discovery's base model fits, and the library candidates present
    in the problem are that stage's pressure coefficients.

    Attributes
    ----------
    output : str                 measured channel (Fx, Fy, Mx, Mz)
    fit_stage : str              the MF stage whose coefficients these are
    kinds : tuple of str         sweep kinds used
    free : tuple of str          MF coefficients fitted in the base model
    """

    output: str
    fit_stage: str
    kinds: tuple[str, ...]
    free: tuple[str, ...]

    @property
    def candidates(self) -> tuple[str, ...]:
        """The fit stage's pressure coefficients
        (:func:`identify.fit.mf.pressure_holdout.is_pressure_coefficient`), by name: the
        library candidates present in the problem, held at their neutral values."""
        return tuple(sorted(c for c in STAGES[self.fit_stage].coefficients
                            if is_pressure_coefficient(c)))


DISCOVERY_STAGES: dict[str, DiscoveryStage] = {
    "Fx": DiscoveryStage("Fx", "Fx0", ("braking_driving",),
                         ("PCX1", "PDX1", "PDX2", "PEX1", "PEX2", "PEX4", "PKX1", "PKX2",
                          "PKX3", "PHX1", "PVX1")),
    "Fy": DiscoveryStage("Fy", "Fy0", ("cornering", "camber"),
                         ("PCY1", "PDY1", "PDY2", "PDY3", "PEY1", "PEY2", "PEY3", "PKY1",
                          "PKY2", "PKY3", "PKY6", "PKY7", "PHY1", "PHY2", "PVY1", "PVY2",
                          "PVY3", "PVY4")),
    "Mx": DiscoveryStage("Mx", "Mx", ("cornering", "camber"), ("QSX1", "QSX2", "QSX3")),
    "Mz": DiscoveryStage("Mz", "Mz0", ("cornering", "camber"),
                         ("QBZ1", "QBZ2", "QCZ1", "QDZ1", "QDZ2", "QDZ3", "QEZ1", "QEZ2",
                          "QHZ1", "QHZ3", "QDZ6", "QDZ8", "QDZ9")),
}
"""Discovery's problems by measured output (:func:`stage_problem`)."""


LOAD_WINDOW = 15
"""Samples of the running median of the load before its steps are looked for (measured loads
are noisy: the raw sample-to-sample change would split sweeps everywhere)."""

ZERO_ALPHA = np.deg2rad(0.5)
"""[rad] A slip-ratio sweep whose median slip angle is below this is at a set slip angle of
zero (the measured angle of a real rig wanders by a few tenths of a degree)."""

SEGMENT_GAP = 10
"""Sample intervals of a time jump that ends a sweep inside a segment of identify.segment (a
few samples dropped by a filter do not)."""


def _moves_and_has(df: pd.DataFrame) -> pd.DataFrame:
    """Per sweep: whether alpha, kappa, gamma move (range > tiny) and are ever nonzero."""
    cols = ["alpha", "kappa", "gamma"]
    g = df.groupby("sweep", sort=False)
    lo, hi = g[cols].min(), g[cols].max()
    mag = df[cols].abs().assign(sweep=df["sweep"]).groupby("sweep", sort=False).max()
    out = pd.DataFrame(index=lo.index)
    for c in cols:
        out[f"moves_{c}"] = (hi[c] - lo[c]) > _TINY
        out[f"has_{c}"] = mag[c] > _TINY
    return out


def label_sweeps(frame: pd.DataFrame, tests: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Add ``sweep`` (int id), ``kind``, ``shape`` and ``session_pos`` columns to a trailer
    table.

    A sweep ends where the running time jumps by more than 1.5 sample intervals, the run
    changes, or the load (running median over :data:`LOAD_WINDOW` samples) changes by more
    than 2 %; in a table segmented by identify.segment (a ``segment_id`` column), where
    each segment is one sweep at one set load, where the segment changes or the time jumps
    by more than :data:`SEGMENT_GAP` sample intervals instead. The kind is the manifest test
    of the run (``tests``: run id -> test) when it is a known one, else it follows from what
    varies. ``session_pos`` is the sample's position
    in the session, -1 .. +1 in row order (runs in manifest order): the drift candidate's
    time axis (:mod:`identify.discover.drift`). Vectorised over samples and sweeps.
    """
    df = frame.reset_index(drop=True).copy()
    run = df["run"].astype(str).to_numpy() if "run" in df else np.zeros(len(df), dtype=str)
    t = df["t"].to_numpy(float) if "t" in df else np.arange(len(df), dtype=float)
    dt = np.diff(t)
    step = np.median(dt[dt > 0]) if np.any(dt > 0) else 1.0
    brk = np.ones(len(df), dtype=bool)
    brk[1:] = (run[1:] != run[:-1]) | (dt <= 0)
    seg = df["segment_id"].to_numpy(float) if "segment_id" in df else np.full(len(df), np.nan)
    labelled = np.isfinite(seg)
    if labelled.any():
        # sweeps found by identify.segment (at one set load each): a segment is one sweep,
        # across the few samples a filter left out of it. The load-step and time-gap rules
        # inside them only cut fragments (1-44 samples, at high slip and low load where the
        # measured load moves by 2 %, or around a dropped sample): a one-sample fragment
        # varies nothing, so it made a metric group ("speed") of its own that weighed as
        # much as a pressure level's cornering sweeps in the thesis error
        by_segment = (seg[1:] != seg[:-1]) | (dt > SEGMENT_GAP * step)
    if not labelled.all():  # the load's running median: needed only where loads end sweeps
        fz = median_filter(df["Fz"].to_numpy(float), size=LOAD_WINDOW, mode="nearest") \
            if len(df) >= LOAD_WINDOW else df["Fz"].to_numpy(float)
        by_load = (dt > 1.5 * step) \
            | (np.abs(np.diff(fz)) > 0.02 * np.maximum(np.abs(fz[:-1]), 1.0))
    both, neither = labelled[1:] & labelled[:-1], ~labelled[1:] & ~labelled[:-1]
    if labelled.all():
        brk[1:] |= by_segment
    elif not labelled.any():
        brk[1:] |= by_load
    else:  # segmented session logs next to test runs: each by its own rule
        brk[1:] |= np.where(both, by_segment, np.where(neither, by_load, True))
    df["sweep"] = np.cumsum(brk) - 1
    df["session_pos"] = session_positions(len(df))
    known = {"cornering", "braking_driving", "combined", "camber", "rolling_resistance"}
    f = _moves_and_has(df)
    kind = np.where(f["has_gamma"] & ~f["has_kappa"], "camber",
                    np.where(f["moves_kappa"], np.where(f["has_alpha"], "combined",
                                                        "braking_driving"),
                             np.where(f["moves_alpha"], "cornering", "rolling_resistance")))
    kinds = pd.Series(kind, index=f.index)
    if tests and "run" in df:
        first_run = df.groupby("sweep", sort=False)["run"].first().astype(str)
        test = first_run.map(lambda r: tests.get(r))
        # a combined-slip test's slip-ratio sweeps at a set slip angle of zero are pure
        # drive/brake sweeps (the TTC drive/brake file holds 0, -3 and -6 deg): ``mfid fit``
        # fits Fx0 on them, and so is the longitudinal force tested here
        set_alpha = df.groupby("sweep", sort=False)["alpha"].median().abs()
        pure = (test == "combined") & f["moves_kappa"] & (set_alpha < ZERO_ALPHA)
        test = test.where(~pure, "braking_driving")
        kinds = kinds.where(~test.isin(known), test)
    df["kind"] = df["sweep"].map(kinds)
    df["shape"] = df["sweep"].map(sweep_shapes(df, f))
    return df


def sweep_shapes(df: pd.DataFrame, flags: pd.DataFrame | None = None) -> dict:
    """Sweep id -> what it varies (``alpha``, ``alpha@gamma``, ``gamma``, ``kappa`` ...)."""
    f = _moves_and_has(df) if flags is None else flags
    cols = ("alpha", "kappa", "gamma")
    out = {}
    for sid, row in zip(f.index, f.itertuples(index=False)):  # one line per sweep
        r = row._asdict()
        moves = [c for c in cols if r[f"moves_{c}"]]
        held = [c for c in cols if c not in moves and r[f"has_{c}"]]
        out[sid] = "+".join(moves or ["speed"]) + ("@" + "+".join(held) if held else "")
    return out


def _param(P: lmfit.Parameters, name: str, value: float, vary: bool,
           lo: float | None = None, hi: float | None = None) -> None:
    tlo, thi = table_bounds(name, value)
    lo = tlo if lo is None else lo
    hi = thi if hi is None else hi
    if vary and not np.isfinite(lo) and not np.isfinite(hi):
        span = max(abs(value), 1.0)
        lo, hi = value - 10 * span, value + 10 * span
    P.add(name, value=float(np.clip(value, lo, hi)), vary=vary, min=lo, max=hi)


def add_parameter(problem: FitProblem, name: str, value: float, *, vary: bool = False,
                  lo: float = -np.inf, hi: float = np.inf) -> FitProblem:
    """A copy of ``problem`` with one more parameter (for problems whose model reads the whole
    .tir: MF stages, camber and rolling-resistance relations)."""

    P = problem.parameters.copy()
    P.add(name, value=float(value), vary=vary, min=lo, max=hi)
    return dataclasses.replace(problem, parameters=P)


def stage_problem(name: str, frame: pd.DataFrame, tir: Mapping[str, float], *,
                  free: tuple[str, ...] | None = None, extra_fixed: Mapping[str, float] = {},
                  mode: int = TRAILER_MODE) -> FitProblem | None:
    """The FitProblem of output ``name`` (a key of :data:`DISCOVERY_STAGES`) on a labelled trailer
    table (:func:`label_sweeps`); None when the table has no sweep of the stage's kinds.

    Parameters
    ----------
    frame : DataFrame
        Columns Fz [N], kappa [-], alpha, gamma [rad], Vx [m/s], p [Pa], the stage's output
        [N or N m], sweep, kind.
    tir : mapping
        Base .tir values (SI): start values of the free coefficients and every fixed key.
    free : tuple of str, optional
        Free coefficients (default: the stage's list).
    extra_fixed : mapping
        Further parameters held fixed (e.g. library candidates at their neutral values).
    """
    stage = DISCOVERY_STAGES[name]
    d = frame[frame["kind"].isin(stage.kinds)].reset_index(drop=True)
    if d.empty or stage.output not in d or d[stage.output].isna().all():
        return None
    d = d[np.isfinite(d[stage.output].to_numpy(float))].reset_index(drop=True)
    cols = {c: d[c].to_numpy(float) for c in ("Fz", "kappa", "alpha", "gamma", "Vx", "p")}
    t = covering({k: float(v) for k, v in tir.items() if isinstance(v, (int, float))}, cols)
    s = prepare(t, cols["Fz"], cols["kappa"], cols["alpha"], cols["gamma"], cols["Vx"],
                p=cols["p"], mode=mode)
    P = lmfit.Parameters()
    for k in (free if free is not None else stage.free):
        _param(P, k, t.get(k, 0.0), True)
    for k in stage.candidates:
        if k not in P:
            _param(P, k, t.get(k, 0.0), False)
    for k, v in extra_fixed.items():
        if k not in P:
            P.add(k, value=float(v), vary=False)
    model = _model(name, t, s)
    extra = {"quantity": stage.output, "Fz_N": cols["Fz"], "gamma_deg": np.rad2deg(cols["gamma"]),
             "alpha_rad": cols["alpha"], "kappa": cols["kappa"], "Vx_mps": cols["Vx"],
             "noise_group": d["sweep"].to_numpy(),
             "metric_group": (d["shape"] if "shape" in d else d["kind"]).to_numpy(),
             "full_tir": True}
    if "session_pos" in d:
        extra["session_pos"] = d["session_pos"].to_numpy(float)
    return FitProblem("MF", name, P, model, d[stage.output].to_numpy(float),
                      level_pressure(cols["p"], d["sweep"].to_numpy()) / 1e5, objective="wls",
                      sweeps=d["sweep"].to_numpy(),
                      unit="N" if stage.output.startswith("F") else "N*m", extra=extra)


#: (.tir min key, max key) -> the trailer column [SI] whose measured values the limits must hold
_LIMITS = (("FZMIN", "FZMAX", "Fz"), ("PRESMIN", "PRESMAX", "p"), ("KPUMIN", "KPUMAX", "kappa"),
           ("ALPMIN", "ALPMAX", "alpha"), ("CAMMIN", "CAMMAX", "gamma"))


def covering(tir: Mapping[str, float], cols: Mapping[str, np.ndarray]) -> dict[str, float]:
    """``tir`` with its validity limits widened to hold every measured value of ``cols``
    (columns Fz [N], p [Pa], kappa [-], alpha, gamma [rad]).

    The limit checks of the trailer mode clip the inputs to the .tir's ranges; a discovery
    problem's points are all measured, and the model must see them as they are. A base .tir
    of another tyre (the bundled passenger-car tyre: 1.5-3.5 bar) clipped every pressure of a
    Formula Student session (0.55-0.83 bar) to one value: every pressure candidate's column
    became a multiple of a fitted one and none was testable.
    """
    out = dict(tir)
    for lo_key, hi_key, col in _LIMITS:
        v = np.asarray(cols.get(col, ()), dtype=float)
        v = v[np.isfinite(v)]
        if not v.size or lo_key not in out or hi_key not in out:
            continue
        out[lo_key] = min(out[lo_key], float(v.min()))
        out[hi_key] = max(out[hi_key], float(v.max()))
    return out


def level_pressure(p: np.ndarray, sweep: np.ndarray) -> np.ndarray:
    """Each point's pressure level [Pa]: its sweep's mean pressure, clustered into levels
    (:func:`identify.discover.design.levels`) and replaced by the level's mean.

    The problem's ``pressure_bar`` groups the points (thesis metric per pressure, noise
    floor, leave-one-pressure-out folds); the model itself takes every sample's measured
    pressure. A measured pressure channel has a value per sample: grouped as it is, every
    sample was its own "pressure" and the per-pressure metric went through ~60k groups of a
    60k-sample problem (the base diagnosis of a TTC session ran for tens of minutes).
    """
    p = np.asarray(p, dtype=float)
    sweep_mean = pd.Series(p).groupby(np.asarray(sweep)).transform("mean").to_numpy()
    lv = levels(sweep_mean)
    out = pd.Series(sweep_mean).groupby(lv).transform("mean").to_numpy(dtype=float, copy=True)
    out[lv < 0] = np.nan
    return out


def _model(name: str, t: Mapping[str, float], s):
    """model(values) -> predictions of stage ``name`` with the other keys from ``t``."""
    if name == "Fx":
        return lambda v: longitudinal.fx0({**t, **v}, s).fx0
    if name == "Fy":
        return lambda v: lateral.fy0({**t, **v}, s).fy0
    lat = lateral.fy0(t, s)
    fy = lateral.fy_combined(t, s, lat)
    if name == "Mx":
        return lambda v: moments.mx({**t, **v}, s, fy.fy)
    if name == "Mz":
        lat0 = lateral.fy0(t, s, zero_camber=True)
        lon = longitudinal.fx0(t, s)
        fx = longitudinal.gx_alpha(t, s) * lon.fx0

        def mz(v):
            P = {**t, **v}
            return aligning.mz(P, s, lat, lat0, fy, fx, lon.kxk).mz
        return mz
    raise KeyError(name)
