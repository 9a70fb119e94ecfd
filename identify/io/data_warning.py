"""The warning record of usable-but-quirky data, and the collector the quirk checks fill."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.core.serial import Serial
from identify.io.csv_rows import RowLines

__all__ = ["DataWarning", "WarningReport", "per_channel", "runs_of"]


@dataclass(frozen=True)
class DataWarning(Serial):
    """One quirk of one run: usable data, cleaned, reported with a count.

    Attributes
    ----------
    file : str
        The data file.
    run : str
        The run id.
    kind : str
        ``time-order``, ``time-gap``, ``nan``, ``dropout``, ``spike`` or ``implausible``.
    channels : tuple of str
        The channels concerned, as the file names them.
    count : int
        Samples affected (for ``time-gap``: the number of gaps).
    total : int
        Samples in the run as read.
    detail : str
        What was found (per-channel counts, the implausible value).
    action : str
        What was done (``"samples dropped"``, ``"channel dropped"`` ...).
    line : int or None
        Line of the first occurrence in a text file.
    """

    file: str
    run: str
    kind: str
    channels: tuple[str, ...]
    count: int
    total: int
    detail: str
    action: str
    line: int | None = None

    def __str__(self) -> str:
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        return (f"{where}: {', '.join(self.channels)}: {self.detail} ({self.count} of "
                f"{self.total} samples); {self.action}")

    #: written after the fields (``to_dict``): ``text`` is the printed line
    serial_derived = {"text": str}


def runs_of(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) positions of the runs of True in a boolean array."""
    edges = np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


class WarningReport:
    """Collects the warnings of one run."""

    def __init__(self, file: str, run: str, total: int, names: Mapping[str, str],
                 first_line: int | RowLines | None) -> None:
        self.file, self.run, self.total, self.names = file, run, total, names
        self.first_line = first_line
        self.rows: np.ndarray | None = None
        self.items: list[DataWarning] = []

    def add(self, kind: str, cols, count: int, detail: str, action: str,
            first: int | None = None) -> None:
        """Record one warning; ``first`` is the position of the first sample concerned."""
        if first is not None and self.rows is not None:
            first = int(self.rows[first]) if first < self.rows.size else None
        line = None if self.first_line is None or first is None else self.first_line + first
        self.items.append(DataWarning(self.file, self.run, kind,
                                      tuple(self.names.get(c, c) for c in cols), int(count),
                                      self.total, detail, action, line))


def per_channel(report: WarningReport, counts: dict[str, int]) -> str:
    return ", ".join(f"{report.names.get(c, c)} {n}" for c, n in counts.items())
