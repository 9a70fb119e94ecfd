"""Trailer points for the MF stages: selection, pressure groups, sweeps and data coverage.

The input is the tidy trailer table of ``identify.io.folder.load_folder(path).trailer``:
columns run, t, Vx, omega, alpha, kappa, gamma, p, Fx, Fy, Fz, Mx, My, Mz (SI, ISO-W).
Nothing here modifies the table.

Effective rolling radius (stage ``geometry``): measured as Re = Vx/omega on free-rolling points
only. MF defines kappa = (omega Re - Vx)/Vx, so Re = Vx (1 + kappa)/omega at any slip; but a
trailer's kappa channel is usually computed from omega with an assumed radius, and then
Vx (1 + kappa)/omega returns that assumed radius, not the tyre's. Free rolling (no drive or
brake torque: the cornering, camber and rolling-resistance runs) has kappa = 0 by definition,
so there Re = Vx/omega uses only the speed channels; the kappa channel serves only to recognise
free rolling (runs without a kappa sweep, |kappa| <= FREE_KAPPA, generous enough for a kappa
computed with a radius 1 % off). The simulator (identify.simulate.trailer) writes omega from
the model's fixed point omega = (1 + kappa) Vx/Re, i.e. Vx/omega = Re at kappa = 0.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd

from identify.fit.mf.stage_specs import NEEDS, PURE_ALPHA, PURE_KAPPA, ZERO_SLIP

REQUIRED = ("run", "Vx", "alpha", "kappa", "gamma", "p", "Fz")
SWEEP_KAPPA = 0.02
"""[-] a run whose kappa spans more than this holds a longitudinal-slip sweep."""
SPAN_QUANTILES = (0.01, 0.99)
"""Quantiles of a run's alpha, kappa and gamma whose difference is the run's span."""
SWEEP_ANGLE = np.deg2rad(1.0)
"""[rad] a run whose alpha or gamma spans more than this holds a lateral sweep."""
SEGMENT_COLUMN = "segment_id"
"""Column of a trailer table that labels the segment (sweep) of each row, where a segmentation
or binning made it (NaN elsewhere): the sweeps of :func:`sweep_ids`."""
LOAD_RESOLUTION = 0.05
"""Load levels closer than this fraction of FNOMIN are one level."""
PRESSURE_RESOLUTION = 5000.0
"""[Pa] pressure levels closer than this are one level."""
SPEED_RESOLUTION = 1.0
"""[m/s] speed levels closer than this are one level."""
FREE_KAPPA = 0.01
"""[-] |kappa| at or below this, in a run without a kappa sweep, is free rolling."""
FREE_MIN_SPEED = 1.0
"""[m/s] free-rolling points below this speed are not used for Re = Vx/omega."""
CAMBER_SPREAD = np.deg2rad(0.5)
"""[rad] the data cover camber when gamma spans more than this."""
SIGN_SHARE = 0.25
"""Slip counts as of both signs (:func:`both_signs`) when the shorter side reaches this fraction
of the longer one's extent, each side's extent its 0.5 % or 99.5 % quantile."""


SWEPT_SLIP = {"lateral": ("alpha", PURE_ALPHA)}
"""Selection of a pure-slip stage -> the slip it sweeps and the pure-slip threshold beyond which
a point is on the sweep (:func:`coverage_missing`): the pure lateral stages Fy0 and Mz0. Fx0's
zero-slip points (the cornering runs at kappa = 0) still count for all its coefficients: on a
real session with drive/brake runs at two of five pressures, holding its pressure-curvature
terms by the swept points alone made the fitted longitudinal force worse on every sample."""


DERIVED = ("Re", "Rl")
"""Stage quantities that are not a column of their own name: Re from Vx and omega, Rl the
``rl`` channel (a stage without them is skipped, not an error)."""


def check_columns(frame: pd.DataFrame, quantities: tuple[str, ...]) -> None:
    """Raise ValueError when a column the MF stages need is missing (``"Re"`` is derived from
    Vx and omega, ``"Rl"`` is the ``rl`` channel; without them the geometry and vertical
    stages are skipped, not an error)."""
    missing = [c for c in REQUIRED + quantities if c not in DERIVED and c not in frame.columns]
    if missing:
        raise ValueError("trailer table lacks column(s) " + ", ".join(missing))


def quantity_values(frame: pd.DataFrame, quantity: str) -> np.ndarray:
    """The measured values of a stage's quantity: the channel itself, for ``"Re"`` the
    effective rolling radius Vx/omega [m], for ``"Rl"`` the loaded radius channel ``rl`` [m]
    (both NaN where omega is missing or not positive: the loaded radius's model reads the
    free radius at the wheel speed)."""
    if quantity not in DERIVED:
        return frame[quantity].to_numpy(float)
    if "omega" not in frame.columns or (quantity == "Rl" and "rl" not in frame.columns):
        return np.full(len(frame), np.nan)
    omega = frame["omega"].to_numpy(float)
    if quantity == "Rl":
        return np.where(omega > 0, frame["rl"].to_numpy(float), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(omega > 0, frame["Vx"].to_numpy(float) / omega, np.nan)


def run_sweeps(frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row: whether its run sweeps kappa (1st to 99th percentile span above SWEEP_KAPPA),
    whether it sweeps alpha or gamma (above SWEEP_ANGLE), and whether it rolls freely (no
    kappa sweep and a median |kappa| at most FREE_KAPPA; an alpha sweep at a held slip ratio
    does not)."""
    # slip spans per run: pandas' own groupby quantiles and median (they skip NaN) over
    # integer run codes, which then index the spans, vectorised where a Python lambda per
    # run and Series.map on the string run ids would loop in Python; callers that select
    # often pass the result on
    codes, runs = pd.factorize(frame["run"], use_na_sentinel=False)
    groups = pd.DataFrame({"run": codes, **{c: frame[c].to_numpy(float)
                                            for c in ("alpha", "kappa", "gamma")}}
                          ).groupby("run", sort=True)
    # robust spans (1st to 99th percentile): a few stray samples of a noisy kappa channel
    # do not make a cornering run a slip-ratio sweep
    span = (groups.quantile(SPAN_QUANTILES[1]) - groups.quantile(SPAN_QUANTILES[0])
            ).reindex(np.arange(runs.size))
    kappa_sweep = (span["kappa"] > SWEEP_KAPPA).to_numpy(bool)
    held = (groups["kappa"].median().abs().reindex(np.arange(runs.size)) > FREE_KAPPA
            ).to_numpy(bool)
    lateral_sweep = ((span["alpha"] > SWEEP_ANGLE) | (span["gamma"] > SWEEP_ANGLE)
                     ).to_numpy(bool)
    return kappa_sweep[codes], lateral_sweep[codes], (~kappa_sweep & ~held)[codes]


Sweeps = tuple[np.ndarray, np.ndarray, np.ndarray]
""":func:`run_sweeps` of a table: (kappa_sweep, lateral_sweep, rolling) per row."""


def rolling_kappa(frame: pd.DataFrame, sweeps: Sweeps | None = None) -> pd.DataFrame:
    """``frame`` with kappa = 0 in the runs that roll freely (:func:`run_sweeps`, or
    ``sweeps`` when the caller has them; a copy when any changes). The table it returns has
    the same run_sweeps (a rolling run's kappa span and median were below the sweep and
    held-slip thresholds, and 0 is too).

    Such a run rolls freely: its slip-ratio channel is the noise of the wheel-speed and radius
    measurement (SL of a cornering run scatters by a few 0.001 about 0; SR, the older TTC
    rounds' stand-in, more), not a slip. Taken as a slip it entered the pure stages' model as
    Kx x noise of Fx (about 2 % of Fz at 0.001) and, through the arm s Fx, as noise on Mz0."""
    rolling = (run_sweeps(frame) if sweeps is None else sweeps)[2]
    k = frame["kappa"].to_numpy(float)
    rolling = rolling & np.isfinite(k) & (k != 0)
    if not rolling.any():
        return frame
    return frame.assign(kappa=np.where(rolling, 0.0, k))


def select(frame: pd.DataFrame, selection: str, quantity: str,
           sweeps: Sweeps | None = None) -> np.ndarray:
    """Row positions of the points a stage fits (finite quantity, positive load).

    Parameters
    ----------
    frame : DataFrame
        The trailer table.
    selection : str
        ``"free_rolling"``, ``"longitudinal"``, ``"lateral"``, ``"combined"``, ``"kappa_slip"``,
        ``"drag"``, ``"any_kappa"``, ``"rolling_runs"`` or ``"all"``
        (see StageDef).
    quantity : str
        The fitted channel (``"Re"``: Vx/omega, ``"Rl"``: rl; see quantity_values).
    sweeps : Sweeps, optional
        :func:`run_sweeps` of ``frame``, when the caller has them.
    """
    a = np.abs(frame["alpha"].to_numpy(float))
    k = np.abs(frame["kappa"].to_numpy(float))
    ok = np.isfinite(quantity_values(frame, quantity)) & (frame["Fz"].to_numpy(float) > 0)
    kappa_sweep, lateral_sweep, rolling = run_sweeps(frame) if sweeps is None else sweeps
    if selection == "free_rolling":
        ok &= ((k <= FREE_KAPPA) & ~kappa_sweep
               & (frame["Vx"].to_numpy(float) >= FREE_MIN_SPEED))
    elif selection == "longitudinal":
        # with the zero-slip points of the rolling runs: Fx at kappa = 0 (the offsets SHx,
        # SVx), measured there at every load, pressure and camber of the cornering programme
        ok &= (a <= PURE_ALPHA) & (kappa_sweep | (rolling & lateral_sweep))
    elif selection == "lateral":
        # in a run that rolls freely kappa is the channel's noise (SL of a real cornering
        # run scatters by a few 0.001), not a slip to select on
        ok &= ((k <= PURE_KAPPA) | rolling) & lateral_sweep
    elif selection == "combined":
        ok &= (a > PURE_ALPHA) & (k > PURE_KAPPA) & ~rolling
    elif selection == "kappa_slip":  # needs combined slip; then alpha = 0 too
        slip = (k > PURE_KAPPA) & ~rolling
        ok &= slip & bool(np.any(ok & slip & (a > PURE_ALPHA)))
    elif selection == "drag":  # combined slip, and the slip angles of the rolling runs
        ok &= (a > PURE_ALPHA) & (((k > PURE_KAPPA) & ~rolling) | (rolling & lateral_sweep))
    elif selection == "any_kappa":  # slip ratio at any slip angle, without combined slip too
        ok &= (k > PURE_KAPPA) & ~rolling
    elif selection == "rolling_runs":  # the freely rolling runs; every run without one
        ok &= rolling if bool(np.any(ok & rolling)) else True
    elif selection != "all":
        raise ValueError(f"unknown selection {selection!r}")
    return np.flatnonzero(ok)


def pressure_groups(frame: pd.DataFrame) -> np.ndarray:
    """Pressure group of every row [bar], rounded to 0.01 bar: the median pressure of its
    sweep (its run, and its segment where the table labels them, :data:`SEGMENT_COLUMN`),
    sweeps whose medians lie within PRESSURE_RESOLUTION of each other merged into one level
    (the median of their rows' sweep medians, as :func:`level_values`). The objective weights
    each group as one pressure (identify.fit.solve.metric.group_weights), and the written .tir's
    PRESMIN/PRESMAX are their range. A TTC run holds every pressure block of the session, so
    a group per run gave one pressure for all three (2.56 bar for 2.12, 2.50 and 2.88), and the
    written limits claimed 2.56-2.57 bar; a rising pressure (several kPa as the tyre warms)
    stays one level. NaN where a sweep has no finite pressure."""
    keys = ["run"] + ([SEGMENT_COLUMN] if SEGMENT_COLUMN in frame.columns else [])
    med = frame.groupby(keys, sort=False, dropna=False)["p"].transform("median").to_numpy(float)
    out = np.full(med.shape, np.nan)
    ok = np.isfinite(med)
    if not ok.any():
        return out
    values, inverse = np.unique(med[ok], return_inverse=True)
    level = np.r_[0, np.cumsum(np.diff(values) > PRESSURE_RESOLUTION)][inverse]
    medians = np.array([np.median(med[ok][level == g]) for g in range(level.max() + 1)])
    out[ok] = np.round(medians[level] / 1e5, 2)
    return out


def sweep_ids(frame: pd.DataFrame, fnomin: float) -> np.ndarray:
    """Sweep number of every row.

    Rows with a :data:`SEGMENT_COLUMN` label (segmented or binned sweeps, whose binned rows are
    no longer in time order) belong to the sweep of their run and segment. The other rows start
    a new sweep at a new run, a time gap (> 1.5 x the median step) or a load step
    (> LOAD_RESOLUTION x FNOMIN). Numbers are consecutive from 0, the labelled sweeps after the
    others.
    """
    run = pd.factorize(frame["run"])[0]
    new = np.r_[True, run[1:] != run[:-1]]
    fz = frame["Fz"].to_numpy(float)
    new[1:] |= np.abs(np.diff(fz)) > LOAD_RESOLUTION * fnomin
    if "t" in frame.columns:
        dt = np.diff(frame["t"].to_numpy(float))
        step = np.median(dt[dt > 0]) if np.any(dt > 0) else np.inf
        new[1:] |= (dt > 1.5 * step) | (dt < 0)
    ids = np.cumsum(new) - 1
    if SEGMENT_COLUMN not in frame.columns:
        return ids
    seg = frame[SEGMENT_COLUMN].to_numpy(float)
    labelled = np.isfinite(seg)
    if not labelled.any():
        return ids
    _, plain = np.unique(ids[~labelled], return_inverse=True)
    _, grouped = np.unique(np.c_[run[labelled], seg[labelled]], axis=0, return_inverse=True)
    out = np.empty(len(frame), dtype=np.int64)
    out[~labelled] = plain
    out[labelled] = int(plain.max(initial=-1)) + 1 + grouped.ravel()
    return out


def both_signs(x: np.ndarray, pure: float) -> bool:
    """Whether the slip ``x`` (alpha [rad] or kappa [-]) covers both signs: each side's extent
    (the 0.5 % and 99.5 % quantiles of the finite values) beyond ``pure`` and at least
    SIGN_SHARE of the other side's. A real drive/brake run's "0 deg" sweep sits a few tenths of
    a degree off zero (the slip-angle channel's offset), which beside sweeps at 3 and 6 deg is
    no second sign for a shift such as RBY3 to be told from a shape: counted by any sample
    beyond the pure-slip threshold (0.25 deg), a sweep 0.4 deg off zero freed RBY3 on such a
    design; a stray sample counted as well."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return False
    neg, pos = -float(np.quantile(x, 0.005)), float(np.quantile(x, 0.995))
    return min(neg, pos) > max(pure, SIGN_SHARE * max(neg, pos))


def levels(x: np.ndarray, resolution: float) -> int:
    """Number of distinct levels of ``x`` (values closer than ``resolution`` merge)."""
    x = np.sort(np.asarray(x, dtype=float)[np.isfinite(x)])
    return 0 if x.size == 0 else int(1 + np.sum(np.diff(x) > resolution))


def level_values(x: np.ndarray, resolution: float) -> np.ndarray:
    """The distinct levels of ``x`` (values closer than ``resolution`` merge), each the median
    of its values, ascending (e.g. the pressures of a test whose pressure channel is measured
    continuously: a few levels, not one value per sample)."""
    x = np.sort(np.asarray(x, dtype=float)[np.isfinite(x)])
    if x.size == 0:
        return x
    group = np.r_[0, np.cumsum(np.diff(x) > resolution)]
    return np.array([np.median(x[group == g]) for g in range(group[-1] + 1)])


@dataclass(frozen=True)
class Coverage:
    """What a stage's points cover (for the identifiability rules of StageDef coefficients).

    Attributes
    ----------
    loads, pressures, speeds : int   numbers of distinct levels
    camber : bool                    gamma varies by more than CAMBER_SPREAD
    kappa_sign, alpha_sign : bool    slip of both signs present (:func:`both_signs`)
    """

    loads: int
    pressures: int
    speeds: int
    camber: bool
    kappa_sign: bool
    alpha_sign: bool

    @classmethod
    def of(cls, frame: pd.DataFrame, fnomin: float) -> Coverage:
        g = frame["gamma"].to_numpy(float)
        k = frame["kappa"].to_numpy(float)
        a = frame["alpha"].to_numpy(float)
        return cls(loads=levels(frame["Fz"].to_numpy(float), LOAD_RESOLUTION * fnomin),
                   pressures=levels(frame["p"].to_numpy(float), PRESSURE_RESOLUTION),
                   speeds=levels(frame["Vx"].to_numpy(float), SPEED_RESOLUTION),
                   camber=bool(g.size and np.ptp(g) > CAMBER_SPREAD),
                   kappa_sign=both_signs(k, PURE_KAPPA),
                   alpha_sign=both_signs(a, PURE_ALPHA))

    def missing(self, needs: tuple[str, ...]) -> str | None:
        """Why the data cannot identify a coefficient with ``needs``, or None."""
        rules = {"load": (self.loads >= 2, "one load level"),
                 "load2": (self.loads >= 3, f"{self.loads} load level(s), 3 needed"),
                 "load3": (self.loads >= 4, f"{self.loads} load level(s), 4 needed"),
                 "pressure": (self.pressures >= 2, "one pressure"),
                 "pressure2": (self.pressures >= 3, f"{self.pressures} pressure(s), 3 needed"),
                 "speed": (self.speeds >= 2, "one speed"),
                 "speed2": (self.speeds >= 3, f"{self.speeds} speed(s), 3 needed"),
                 "camber": (self.camber, "no camber variation"),
                 "kappa_sign": (self.kappa_sign, "slip of one sign only"),
                 "alpha_sign": (self.alpha_sign, "slip angles of one sign only")}
        for need in needs:
            ok, why = rules[need]
            if not ok:
                return "data: " + why
        return None


def coverage_missing(pts: pd.DataFrame, selection: str, fnomin: float,
                     names: tuple[str, ...] | list[str]) -> dict[str, str]:
    """Coefficient -> why the points ``pts`` of a stage (selection ``selection``) cannot
    identify it (:meth:`Coverage.missing` of its NEEDS), for the ``names`` they cannot.

    The pure lateral stages' points (``lateral``: :data:`SWEPT_SLIP`) include points at zero
    slip angle: the drive/brake runs', at their cambers, loads and pressures. Those measure the
    offsets (ZERO_SLIP of
    identify.fit.mf.stage_specs), not the shape along the slip: a shaping coefficient's load,
    pressure and camber levels are counted on the points beyond the pure-slip threshold only
    (every point when none is), the offsets' on every point."""
    whole = Coverage.of(pts, fnomin)
    swept = whole
    if selection in SWEPT_SLIP:
        var, pure = SWEPT_SLIP[selection]
        beyond = np.abs(pts[var].to_numpy(float)) > pure
        if beyond.any() and not beyond.all():
            part = Coverage.of(pts[beyond], fnomin)
            swept = dataclasses.replace(whole, loads=part.loads, pressures=part.pressures,
                                        camber=part.camber)
    out = {}
    for n in names:
        why = (whole if n in ZERO_SLIP else swept).missing(NEEDS.get(n, ()))
        if why:
            out[n] = why
    return out
