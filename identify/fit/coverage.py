"""What the trailer data can identify, per MF stage, before any fitting.

:func:`mf_coverage` answers, for each MF stage (identify.fit.mf.stage_specs.STAGES): which of
its points the data hold (loads, pressures, cambers, speeds and slip ranges present), which of
its coefficients the coverage rules (``NEEDS``) leave identifiable, and whether the stage can be
fitted at all. A stage without its data is skipped with one line that says why, e.g.
``"Fx0: no slip-ratio sweep"``; its coefficients then keep their input or default values (the
workflow marks them so in the .tir key sources and fit.json).

A stage is skipped when

- a channel it needs is absent or was dropped as implausible while loading (``unavailable``
  names those channels and why): the fitted quantity (Fx, Fy, Mz, Mx, My), the wheel speed
  omega for the geometry stage, the loaded radius rl and omega for the vertical stage, and
  kappa for every stage (the model takes it, and the
  pure-slip points are told apart by it);
- the sweep it needs is not in the data: a slip-ratio sweep (a run whose kappa spans more than
  ``mf_data.SWEEP_KAPPA``) at zero slip angle for Fx0, at a non-zero slip angle for the
  combined Fy stage (noise on a cornering run's kappa is no combined-slip data), at any slip
  angle for the Mz stage (its arm s of Fx acts at zero slip angle too), and for the Fx stage
  either that or a slip-angle sweep of a rolling run (its drag, Gxa Fx0 at kappa = 0); a
  slip-angle or camber sweep for Fy0 and Mz0;
- it has fewer than :data:`MIN_POINTS` points;
- a stage it builds on is skipped (Fx on Fx0, Fy on Fy0, Mz on Mz0 and Fx0).

The identifiable coefficients are those whose coverage needs are met; the sensitivity screen
of the fit itself may hold more (identify.fit.mf.screen), and fit.json lists those as held.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from identify.core.serial import Serial
from identify.fit.mf import stage_data as mf_data
from identify.fit.mf.stage_specs import DEFAULT_STAGES, PURE_ALPHA, STAGES
from identify.model.parameters import spec

__all__ = ["MIN_POINTS", "StageCoverage", "coverage_text", "mf_coverage"]

MIN_POINTS = 50
"""Fewest points a stage is fitted on."""

SWEPT_CAMBER_DEG = 1.0
"""A stage's camber counts as swept when its span exceeds the spread of its merged levels by
more than this [deg] (levels closer than 0.5 deg merge, so a sweep in fine steps is one
level: its range, not that level, says what the data hold)."""
UPSTREAM = {"Fx": ("Fx0",), "Fy": ("Fy0",), "Mz": ("Mz0", "Fx0")}
"""Stages each combined stage builds on (skipped with them)."""

_CHANNEL_NAMES = {"omega": "wheel speed (omega)", "kappa": "slip ratio (kappa)",
                  "rl": "loaded radius (rl)"}


@dataclass(frozen=True)
class StageCoverage(Serial):
    """What the data hold for one MF stage.

    Attributes
    ----------
    stage : str                     stage name
    points : int                    points the stage's selection finds
    runs : tuple of str             runs they come from
    loads : tuple of float          load levels [N] (median of each level)
    pressures : tuple of float      pressure levels [Pa]
    cambers : tuple of float        inclination levels [deg] (values closer than 0.5 deg
                                    merge, so a camber sweep is one level)
    speeds : tuple of float         speed levels [m/s]
    alpha_deg : tuple of float      (min, max) slip angle [deg]; () without points
    kappa : tuple of float          (min, max) slip ratio [-]; () without points
    camber_deg : tuple of float     (min, max) inclination [deg]; () without points
    identifiable : tuple of str     coefficients the coverage rules leave free
    not_identifiable : mapping      coefficient -> why the data cannot identify it
    skipped : str                   why the stage is not fitted ("" when it is)
    """

    stage: str
    points: int
    runs: tuple[str, ...] = ()
    loads: tuple[float, ...] = ()
    pressures: tuple[float, ...] = ()
    cambers: tuple[float, ...] = ()
    speeds: tuple[float, ...] = ()
    alpha_deg: tuple[float, ...] = ()
    kappa: tuple[float, ...] = ()
    camber_deg: tuple[float, ...] = ()
    identifiable: tuple[str, ...] = ()
    not_identifiable: Mapping[str, str] = field(default_factory=dict)
    skipped: str = ""

    @property
    def camber_swept(self) -> bool:
        """Camber was swept: its span is wider than its levels (merged at 0.5 deg) account
        for by more than SWEPT_CAMBER_DEG, so the levels alone would hide the range."""
        if len(self.camber_deg) != 2 or not self.cambers:
            return False
        span = self.camber_deg[1] - self.camber_deg[0]
        return span > (max(self.cambers) - min(self.cambers)) + SWEPT_CAMBER_DEG

    def camber_text(self, fmt: str = ".1f") -> str:
        """The cambers [deg]: ``"-8.0 .. 8.0 swept"`` for a swept camber, else the levels
        (``"-4.0 0.0 4.0"``); "-" without points."""
        if self.camber_swept:
            lo, hi = self.camber_deg
            return f"{lo:{fmt}} .. {hi:{fmt}} swept"
        return " ".join(format(v, fmt) for v in self.cambers) or "-"

    @property
    def fitted(self) -> bool:
        """The stage has its data (it is fitted)."""
        return not self.skipped

    def line(self) -> str:
        """One line: ``"Fx0: no slip-ratio sweep"`` for a skipped stage, else what it holds
        and how many coefficients are identifiable."""
        if self.skipped:
            return f"{self.stage}: {self.skipped}"
        cambers = (f"camber {self.camber_text().removesuffix(' swept')} deg swept"
                   if self.camber_swept
                   else f"{len(self.cambers)} camber(s)")
        return (f"{self.stage}: {self.points} points; {len(self.loads)} load(s), "
                f"{len(self.pressures)} pressure(s), {cambers}; "
                f"{len(self.identifiable)} of {len(self.identifiable) + len(self.not_identifiable)}"
                " coefficients identifiable")


def _levels(x: np.ndarray, resolution: float) -> tuple[float, ...]:
    """Distinct levels of ``x`` (values closer than ``resolution`` merge), each the median of
    its values, ascending."""
    x = np.sort(np.asarray(x, dtype=float)[np.isfinite(x)])
    if x.size == 0:
        return ()
    group = np.r_[0, np.cumsum(np.diff(x) > resolution)]
    return tuple(float(np.median(x[group == g])) for g in range(group[-1] + 1))


def _span(x: np.ndarray) -> tuple[float, ...]:
    x = np.asarray(x, dtype=float)[np.isfinite(x)]
    return (float(x.min()), float(x.max())) if x.size else ()


def _channel_reason(stage: str, trailer: pd.DataFrame,
                    unavailable: Mapping[str, str]) -> str:
    sd = STAGES[stage]
    # every stage's model and selection take kappa (pure-slip points are |kappa| ~ 0)
    needed = {"Re": ["omega"], "Rl": ["rl", "omega"]}.get(sd.quantity, [sd.quantity]) + ["kappa"]
    for col in needed:
        name = _CHANNEL_NAMES.get(col, col)
        if col in unavailable and unavailable[col] != "absent":
            return f"{name} {unavailable[col]}"
        if col not in trailer.columns or not trailer[col].notna().any():
            return f"no {name} channel"
    return ""


def _sweep_reason(stage: str, trailer: pd.DataFrame, kappa_sweep: np.ndarray,
                  angle_sweep: np.ndarray) -> str:
    a = np.abs(trailer["alpha"].to_numpy(float))
    if stage == "Fx0" and not kappa_sweep.any():
        return "no slip-ratio sweep"
    if stage == "Fx0" and not (kappa_sweep & (a <= PURE_ALPHA)).any():
        return "no slip-ratio sweep at zero slip angle"
    if stage in ("Fx", "Mz") and not kappa_sweep.any():  # Fx0, which both take, neither
        return "no slip-ratio sweep"
    if stage == "Fx" and not (kappa_sweep & (a > PURE_ALPHA)).any() and not (
            ~kappa_sweep & angle_sweep).any():
        return "no slip-ratio sweep at a non-zero slip angle and no slip-angle sweep"
    if stage == "Fy" and not (kappa_sweep & (a > PURE_ALPHA)).any():
        return ("no slip-ratio sweep" if not kappa_sweep.any()
                else "no slip-ratio sweep at a non-zero slip angle (combined slip)")
    if stage in ("Fy0", "Mz0") and not angle_sweep.any():
        return "no slip-angle or camber sweep"
    return ""


def mf_coverage(trailer: pd.DataFrame, fnomin: float, *,
                stages: Sequence[str] = DEFAULT_STAGES,
                unavailable: Mapping[str, str] | None = None) -> tuple[StageCoverage, ...]:
    """The coverage table of the MF stages (see the module notes).

    Parameters
    ----------
    trailer : DataFrame
        The trailer table the stages are fitted on (identify.fit.mf.stage_data).
    fnomin : float
        Nominal load [N] (load levels closer than mf_data.LOAD_RESOLUTION x FNOMIN merge).
    stages : sequence of str
        Stages, in fit order.
    unavailable : mapping, optional
        Tidy channel -> why it cannot be used (``"dropped as implausible: ..."``).

    Returns
    -------
    tuple of StageCoverage
        One per stage, in order.
    """
    unavailable = dict(unavailable or {})
    # the table and its sweeps as the stages fit them (identify.fit.mf.problem.stage_problem):
    # 1st to 99th percentile spans, so a stray sample does not make a run a sweep, and a
    # freely rolling run's kappa, the channel's noise, taken as 0 (the same sweeps after it)
    sweeps = mf_data.run_sweeps(trailer)
    trailer = mf_data.rolling_kappa(trailer, sweeps)
    kappa_sweep, angle_sweep, _ = sweeps
    out: dict[str, StageCoverage] = {}
    for stage in stages:
        sd = STAGES[stage]
        why = _channel_reason(stage, trailer, unavailable) or _sweep_reason(
            stage, trailer, kappa_sweep, angle_sweep)
        # the stage's own selection: its combined points are those of the runs that do not
        # roll freely (a cornering run's noisy kappa is not combined slip; an alpha sweep at a
        # held slip ratio is)
        rows = (np.array([], dtype=int) if why
                else mf_data.select(trailer, sd.selection, sd.quantity, sweeps))
        if not why and rows.size < MIN_POINTS:
            why = f"{rows.size} point(s), {MIN_POINTS} needed"
        up = [u for u in UPSTREAM.get(stage, ()) if u in out and out[u].skipped]
        if not why and up:
            why = f"builds on {', '.join(up)}, which is skipped"
        pts = trailer.iloc[rows]
        names = [n for n in sd.coefficients if spec(n).fit_default_vary]
        blocked = (mf_data.coverage_missing(pts, sd.selection, fnomin, names) if rows.size
                   else dict.fromkeys(names, "stage skipped"))
        out[stage] = StageCoverage(
            stage=stage, points=int(rows.size),
            runs=tuple(str(r) for r in pd.unique(pts["run"])),
            loads=_levels(pts["Fz"], mf_data.LOAD_RESOLUTION * fnomin),
            pressures=_levels(pts["p"], mf_data.PRESSURE_RESOLUTION),
            cambers=_levels(np.rad2deg(pts["gamma"].to_numpy(float)), 0.5),
            speeds=_levels(pts["Vx"], mf_data.SPEED_RESOLUTION),
            alpha_deg=_span(np.rad2deg(pts["alpha"].to_numpy(float))),
            kappa=_span(pts["kappa"]),
            camber_deg=_span(np.rad2deg(pts["gamma"].to_numpy(float))),
            identifiable=tuple(n for n in names if n not in blocked),
            not_identifiable=blocked, skipped=why)
    return tuple(out[s] for s in stages)


def coverage_text(table: Sequence[StageCoverage]) -> list[str]:
    """The coverage table as printable lines: one per stage (loads in kN, pressures in kPa,
    cambers in deg, slip ranges), then one line per skipped stage saying why."""
    lines = [f"{'stage':<9}{'points':>8}  {'loads [kN]':<24}{'p [kPa]':<18}"
             f"{'camber [deg]':<19}{'alpha [deg]':<15}{'kappa':<15}identifiable"]
    for c in table:
        if c.skipped:
            lines.append(f"{c.stage:<9}{c.points:>8}  skipped")
            continue
        lines.append(
            f"{c.stage:<9}{c.points:>8}  {_join(c.loads, 1e-3, '.1f'):<24}"
            f"{_join(c.pressures, 1e-3, '.0f'):<18}{c.camber_text():<19}"
            f"{_join(c.alpha_deg, 1, '.1f', '..'):<15}{_join(c.kappa, 1, '.2f', '..'):<15}"
            f"{len(c.identifiable)}/{len(c.identifiable) + len(c.not_identifiable)}")
    lines += [f"skipped {c.stage}: {c.skipped}" for c in table if c.skipped]
    return lines


def _join(values: Sequence[float], scale: float, fmt: str, sep: str = " ") -> str:
    if not values:
        return "-"
    text = sep.join(format(v * scale, fmt) for v in values)
    return text if len(text) <= 22 else text[:19] + "..."
