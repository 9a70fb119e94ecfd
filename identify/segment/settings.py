"""Settings of the segmentation (all thresholds in one frozen record, JSON round trip)."""
from __future__ import annotations

from dataclasses import dataclass

from identify.core.serial import Serial

__all__ = ["CONDITIONS", "SegmentSettings"]

#: The drifting condition channels whose levels are found (alpha: set slip angle of the
#: slip-ratio sweeps only).
CONDITIONS = ("Fz", "p", "gamma", "Vx")


@dataclass(frozen=True)
class SegmentSettings(Serial):
    """Thresholds of :func:`identify.segment.segment_trailer`.

    Attributes
    ----------
    smooth_s : float
        Window of the running median the condition channels are smoothed with [s].
    rate_Fz, rate_p : float
        Largest change of the smoothed load and pressure over one second, as a fraction of the
        run's median, for a sample to be quasi-steady [1/s].
    rate_gamma_deg : float
        The same for the inclination angle [deg/s].
    rate_Vx : float
        The same for the speed [m/s^2].
    min_duration_s : float
        Shortest quasi-steady stretch that counts as a segment [s].
    gap_s : float
        A time step longer than this breaks a segment [s].
    resolution_Fz, resolution_p : float
        Segment medians further apart than this fraction of their value are different levels.
    resolution_gamma_deg, resolution_alpha_deg : float
        The same in degrees.
    resolution_Vx : float
        The same in m/s.
    min_span_alpha_deg, min_span_kappa : float
        Smallest 1-99 % span of the swept variable in a segment that is a sweep.
    sweep_fraction : float
        A sweep must span at least this fraction of a full sweep of its variable in the run
        (identify.segment.plateaus.full_span; smaller ones are ``partial``: a warm-up
        wiggle, a stray set-up move).
    warmup_ratio : float
        A segment whose swept variable travels more than this many times its span (total
        variation / span; a sweep 0 -> +A -> -A -> 0 gives 2) is a warm-up.
    set_alpha_deg : float
        Samples of a slip-ratio sweep further than this from its set slip angle are dropped
        (the slip-angle ramps between set points).
    cold_fence : float
        A tread centre temperature more than this many interquartile ranges below the lower
        quartile of its run's sweep samples is below the run's working range, one condition
        of a cold sample (identify.segment.filters, ``cold tread``) [-].
    min_speed : float
        Speed below which a sample is dropped [m/s].
    revolution_average : bool
        Average every channel over one wheel revolution (against wheel eccentricity).
    bin_alpha_deg, bin_kappa : float or None
        Bin width of the slip-angle / slip-ratio sweeps (None: no binning).
    bin_passes : bool
        One point per bin and pass of a sweep, not per bin (identify.segment.filters,
        ``binning``).
    """

    smooth_s: float = 1.0
    rate_Fz: float = 0.05
    rate_p: float = 0.005
    rate_gamma_deg: float = 0.2
    rate_Vx: float = 0.3
    min_duration_s: float = 2.0
    gap_s: float = 2.0
    resolution_Fz: float = 0.05
    resolution_p: float = 0.05
    resolution_gamma_deg: float = 0.5
    resolution_alpha_deg: float = 1.0
    resolution_Vx: float = 1.0
    min_span_alpha_deg: float = 2.0
    min_span_kappa: float = 0.03
    sweep_fraction: float = 0.5
    warmup_ratio: float = 4.5
    set_alpha_deg: float = 0.5
    cold_fence: float = 1.0
    min_speed: float = 2.0
    revolution_average: bool = True
    bin_alpha_deg: float | None = None
    bin_kappa: float | None = None
    bin_passes: bool = False
