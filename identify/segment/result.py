"""What a segmentation found: condition levels, segments, filter counts (JSON round trip).

These small frozen records are what a report shows and what a fit records beside its result:
:class:`Segmentation` has no arrays, only numbers and names, so ``to_dict`` / ``from_dict``
round-trip it through JSON exactly.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from identify.core.serial import Serial

__all__ = ["CONDITION_UNITS", "FilterCount", "Level", "Segment", "Segmentation"]

#: The SI unit of each condition channel the levels are found for.
CONDITION_UNITS = {"Fz": "N", "p": "Pa", "gamma": "rad", "Vx": "m/s", "alpha": "rad"}


@dataclass(frozen=True)
class Level(Serial):
    """One quasi-steady level of a condition channel (SI).

    Attributes
    ----------
    channel : str
        ``Fz``, ``p``, ``gamma``, ``Vx`` (all sweeps) or ``alpha`` (the set slip angle of the
        slip-ratio sweeps).
    index : int
        Position among the channel's levels, in increasing value.
    value : float
        Sample-weighted median of the segment medians in the level.
    low, high : float
        Smallest and largest segment median in the level (the drift between segments).
    segments : int
        Sweep segments at this level.
    samples : int
        Samples of those segments.
    """

    channel: str
    index: int
    value: float
    low: float
    high: float
    segments: int
    samples: int


@dataclass(frozen=True)
class Segment(Serial):
    """A stretch of one run at quasi-steady conditions, or a warm-up or transition.

    Attributes
    ----------
    run : str
        The run.
    kind : str
        ``sweep`` (kept), ``warmup``, ``steady`` (no sweep: a pause, the tyre lifted),
        ``partial`` (a sweep too small to be one of the run's) or ``transition`` (conditions
        moving).
    sweep : str
        The swept variable of a sweep: ``alpha`` or ``kappa`` ("" otherwise).
    start, stop : int
        Row positions in the run's table, half-open.
    t_start, t_end : float
        Times of the first and last sample [s].
    levels : mapping
        Condition channel -> level index (sweeps only).
    medians : mapping
        Condition channel -> the segment's median [SI].
    kept : int
        Samples kept after the filters (sweeps).
    """

    run: str
    kind: str
    sweep: str
    start: int
    stop: int
    t_start: float
    t_end: float
    levels: Mapping[str, int] = field(default_factory=dict)
    medians: Mapping[str, float] = field(default_factory=dict)
    kept: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "levels", MappingProxyType(dict(self.levels)))
        object.__setattr__(self, "medians", MappingProxyType(dict(self.medians)))


@dataclass(frozen=True)
class FilterCount(Serial):
    """One named filter and how many samples it removed.

    ``applied`` is False (with ``note`` saying why) when the data lack what the filter needs.
    """

    name: str
    removed: int
    remaining: int
    applied: bool
    note: str


@dataclass(frozen=True)
class Segmentation(Serial):
    """The segmentation of a trailer table: levels, segments, filters, sample counts.

    Attributes
    ----------
    levels : mapping
        Condition channel -> its levels (increasing).
    segments : tuple of Segment
        Every segment of every run, in time order per run.
    filters : tuple of FilterCount
        The filters in the order applied.
    samples : int
        Rows of the table segmented.
    in_sweeps : int
        Rows inside sweep segments (before the filters).
    kept : int
        Rows of the result (after the filters; bins when binned).
    settings : mapping
        The settings used (JSON-safe).
    """

    levels: Mapping[str, tuple[Level, ...]]
    segments: tuple[Segment, ...]
    filters: tuple[FilterCount, ...]
    samples: int
    in_sweeps: int
    kept: int
    settings: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "levels", MappingProxyType(
            {k: tuple(v) for k, v in self.levels.items()}))
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))

    def level_values(self, channel: str) -> tuple[float, ...]:
        """The level values of a condition channel [SI], increasing."""
        return tuple(lv.value for lv in self.levels.get(channel, ()))

    def counts(self) -> dict[str, int]:
        """Segments per kind."""
        out: dict[str, int] = {}
        for s in self.segments:
            out[s.kind] = out.get(s.kind, 0) + 1
        return out

