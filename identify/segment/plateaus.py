"""Quasi-steady stretches of one run and what each holds (a sweep, a warm-up, nothing).

A sample is quasi-steady when none of the condition channels (load, pressure, inclination,
speed), smoothed by a running median over ``smooth_s``, changes by more than its rate limit
over one second around it. While the slip is being swept, the channels that respond to the
slip (:data:`FOLLOWS_SLIP`: the load, whose control lags the side and longitudinal force by up
to a quarter of the load at a high slip; the gas pressure, which moves with the tyre's
deflection and heat; the speed, which droops with the braking force) are not tested: a test
programme changes its set points with the slip at rest or while the logger pauses, so their
drift during a sweep is the sweep's, not a new set point. The inclination is set by the rig
and does not follow the slip; it is tested throughout. A maximal run of quasi-steady samples
at least ``min_duration_s`` long (broken at time gaps) is a plateau; what lies between
plateaus is a transition.

Each plateau is then classified by its slip channels, smoothed over 0.25 s and taken every
0.1 s (so that noise does not add up): of the two (alpha, kappa) whose 1-99 % span reaches the
minimum, the swept variable is the one that moves (faster than 1 deg/s, 0.015/s) for more of
the time (a slip-ratio sweep after the tail of a warm-up wiggle, or before a slip-angle ramp,
is a slip-ratio sweep); the total variation over the span says how often it was traversed. A
sweep (0 -> +A -> -A -> 0: ratio 2) goes up to ``warmup_ratio``; more is a warm-up (the slip
angle oscillating); a span below the minimum, or below ``sweep_fraction`` of the run's
full sweep (:func:`full_span`), is ``steady`` or ``partial``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter1d, median_filter, minimum_filter1d

from identify.segment.settings import CONDITIONS, SegmentSettings

__all__ = [
    "FOLLOWS_SLIP",
    "MOVING_ALPHA",
    "MOVING_KAPPA",
    "Plateau",
    "classify",
    "find_plateaus",
    "full_span",
    "interval",
    "running_median",
    "slip_moving",
    "steady_mask",
]

#: Rates above which the slip angle [rad/s] and the slip ratio [1/s] count as moving.
MOVING_ALPHA = np.deg2rad(1.0)
MOVING_KAPPA = 0.015
#: The condition channels whose drift while the slip moves belongs to the sweep (see module).
FOLLOWS_SLIP = ("Fz", "p", "Vx")


@dataclass(frozen=True)
class Plateau:
    """One quasi-steady stretch of a run: positions, medians [SI] and slip content."""

    start: int
    stop: int
    medians: dict
    ends: dict
    alpha_span: float
    kappa_span: float
    alpha_ratio: float
    kappa_ratio: float
    alpha_moving: float
    kappa_moving: float


def interval(t: np.ndarray) -> float:
    """The sample interval [s]: the median time step."""
    return float(np.median(np.diff(t))) if t.size > 1 else 1.0


def running_median(x: np.ndarray, n: int) -> np.ndarray:
    """Running median over ``n`` samples (made odd), ends held."""
    n = max(int(n) // 2 * 2 + 1, 1)
    return median_filter(np.asarray(x, dtype=float), size=n, mode="nearest")


def slip_moving(cols: dict[str, np.ndarray], t: np.ndarray,
                s: SegmentSettings) -> np.ndarray:
    """Samples where the slip angle or the slip ratio is being swept: the channel, smoothed
    over 0.25 s, spans at least half of what it travels at the moving rate
    (:data:`MOVING_ALPHA`, :data:`MOVING_KAPPA`) over the ``smooth_s`` window about the sample
    (half: at the turn of a sweep the window holds the way up and the way back)."""
    dt = interval(t)
    n = max(round(s.smooth_s / dt), 1) // 2 * 2 + 1
    out = np.zeros(t.size, dtype=bool)
    for c, rate in (("alpha", MOVING_ALPHA), ("kappa", MOVING_KAPPA)):
        x = running_median(cols[c], max(round(0.25 / dt), 1))
        if not np.isfinite(x).all():
            x = np.where(np.isfinite(x), x, np.nanmedian(x) if np.isfinite(x).any() else 0.0)
        span = maximum_filter1d(x, n, mode="nearest") - minimum_filter1d(x, n, mode="nearest")
        out |= span >= 0.5 * rate * n * dt
    return out


def steady_mask(cols: dict[str, np.ndarray], t: np.ndarray,
                s: SegmentSettings) -> np.ndarray:
    """Quasi-steady samples: every condition channel within its rate limit, the channels that
    follow the slip only where it is at rest (see module)."""
    dt = interval(t)
    n = max(round(s.smooth_s / dt), 1)
    h = n // 2
    i = np.arange(t.size)
    lo, hi = np.clip(i - h, 0, t.size - 1), np.clip(i + h, 0, t.size - 1)
    span_t = np.maximum(t[hi] - t[lo], dt)
    limits = {"Fz": s.rate_Fz * abs(float(np.median(cols["Fz"]))),
              "p": s.rate_p * abs(float(np.median(cols["p"]))),
              "gamma": np.deg2rad(s.rate_gamma_deg), "Vx": s.rate_Vx}
    moving = slip_moving(cols, t, s)
    ok = np.ones(t.size, dtype=bool)
    for c in CONDITIONS:
        x = running_median(cols[c], n)
        steady = np.abs(x[hi] - x[lo]) / span_t <= limits[c]
        ok &= (steady | moving) if c in FOLLOWS_SLIP else steady
    return ok


def find_plateaus(ok: np.ndarray, t: np.ndarray,
                  s: SegmentSettings) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop positions of the plateaus (quasi-steady, unbroken, long enough)."""
    breaks = np.concatenate(([False], np.diff(t) > s.gap_s))
    mask = ok.astype(np.int8)
    edges = np.diff(np.concatenate(([0], mask, [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    # split at time gaps inside a run of quasi-steady samples
    cut = np.flatnonzero(breaks & ok)
    if cut.size:
        starts = np.sort(np.concatenate((starts, cut)))
        stops = np.sort(np.concatenate((stops, cut)))
        keep = stops > starts
        starts, stops = starts[keep], stops[keep]
    long = (t[np.maximum(stops - 1, starts)] - t[starts]) >= s.min_duration_s
    return starts[long], stops[long]


def _shape(x: np.ndarray, dt: float, moving: float) -> tuple[float, float, float]:
    """1-99 % span, total variation / span, and the fraction of the time it moves faster than
    ``moving`` [per s], of a slip channel (smoothed over 0.25 s, taken every 0.1 s)."""
    step = max(round(0.1 / dt), 1)
    if x.size < 3 * step:
        return 0.0, 0.0, 0.0
    y = running_median(x, max(round(0.25 / dt), 1))[::step]
    lo, hi = np.percentile(y, [1, 99])
    span = float(hi - lo)
    dy = np.abs(np.diff(y))
    moves = float(np.mean(dy > moving * step * dt))
    return span, (float(dy.sum()) / span if span > 0 else 0.0), moves


def describe(cols: dict[str, np.ndarray], t: np.ndarray, starts, stops) -> list[Plateau]:
    """Medians of the conditions, their change from the plateau's first to its last tenth
    (``ends``: the medians of the two tenths apart [SI]) and the slip content of each
    plateau."""
    dt = interval(t)
    out = []
    for a, b in zip(starts, stops):  # a few hundred plateaus, each handled as a whole array
        med = {c: float(np.median(cols[c][a:b])) for c in CONDITIONS}
        tenth = max((b - a) // 10, 1)
        ends = {c: float(abs(np.median(cols[c][b - tenth:b]) - np.median(cols[c][a:a + tenth])))
                for c in CONDITIONS}
        sa, ra, ma = _shape(cols["alpha"][a:b], dt, MOVING_ALPHA)
        sk, rk, mk = _shape(cols["kappa"][a:b], dt, MOVING_KAPPA)
        out.append(Plateau(int(a), int(b), med, ends, sa, sk, ra, rk, ma, mk))
    return out


def full_span(spans: list[float]) -> float:
    """The span of a full sweep of the run: the largest that at least a quarter of the
    candidate plateaus (two at least) reach. A test programme repeats its sweep at every
    set point; one plateau stretched by a stray excursion (a slip-ratio spike as the wheel
    slows, a lock-up at the end of a drive/brake run) would otherwise make every real sweep
    look partial."""
    if not spans:
        return 0.0
    ordered = np.sort(spans)[::-1]
    k = min(len(ordered), max(2, -(-len(ordered) // 4)))
    return float(ordered[k - 1])


def classify(plateaus: list[Plateau], s: SegmentSettings) -> list[tuple[str, str]]:
    """(kind, swept variable) of each plateau: ``sweep``, ``warmup``, ``partial`` or
    ``steady``; ``alpha``, ``kappa`` or ""."""
    min_a, min_k = np.deg2rad(s.min_span_alpha_deg), s.min_span_kappa
    max_a = full_span([p.alpha_span for p in plateaus
                       if p.alpha_ratio <= s.warmup_ratio and p.alpha_span >= min_a])
    max_k = full_span([p.kappa_span for p in plateaus
                       if p.kappa_ratio <= s.warmup_ratio and p.kappa_span >= min_k])
    out = []
    for p in plateaus:
        fa = p.alpha_span / max_a if max_a > 0 and p.alpha_span >= min_a else 0.0
        fk = p.kappa_span / max_k if max_k > 0 and p.kappa_span >= min_k else 0.0
        if fa == 0.0 and fk == 0.0:
            out.append(("steady", ""))
            continue
        alpha_first = (p.alpha_moving, fa) >= (p.kappa_moving, fk) if fa and fk else fa > 0
        var, frac, ratio = (("alpha", fa, p.alpha_ratio) if alpha_first
                            else ("kappa", fk, p.kappa_ratio))
        if ratio > s.warmup_ratio:
            out.append(("warmup", var))
        elif frac < s.sweep_fraction:
            out.append(("partial", var))
        else:
            out.append(("sweep", var))
    return out
