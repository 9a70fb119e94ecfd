"""Page layout shared by every report page: landscape A4 ``Figure`` objects (no pyplot state),
title and footer, colours per pressure and per load, plain text tables.

Every page builder returns a list of ``(title, Figure)`` (:data:`Page`);
:mod:`identify.report.pdf` writes them.
"""
from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure

from identify.core.version import __version__

PAGE = (11.69, 8.27)  # landscape A4 [in]
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
STYLES = ("-", "--", ":", "-.")
RED = "#b00020"
ORANGE = "#b35900"
GREY = "#666666"

Page = tuple[str, Figure]


def new_page(title: str, subtitle: str = "") -> Figure:
    fig = Figure(figsize=PAGE)
    # the subtitle's two lines end above 0.88, where the pages' tables and panels start
    fig.text(0.04, 0.965, title, fontsize=15, weight="bold", va="top")
    if subtitle:
        lines = textwrap.wrap(subtitle, 165)
        if len(lines) > 2:
            lines = lines[:2]
            lines[1] = lines[1][:160] + " ..."
        fig.text(0.04, 0.93, "\n".join(lines), fontsize=9, color=GREY, va="top",
                 linespacing=1.15)
    return fig


def footer(fig: Figure, fd, text: str = "") -> None:
    left = f"{fd.tyre_id} - mfid {__version__}"
    fig.text(0.04, 0.02, left, fontsize=7, color=GREY)
    if text:
        fig.text(0.96, 0.02, text, fontsize=7, color=GREY, ha="right")


def pressure_colours(pressures: Sequence[float]) -> dict[float, Any]:
    """One colour per pressure, ordered from low (dark) to high (light)."""
    ps = sorted({round(float(p), 4) for p in pressures if math.isfinite(float(p))})
    cmap = colormaps["viridis"]
    if len(ps) == 1:
        return {ps[0]: cmap(0.35)}
    return {p: cmap(0.05 + 0.8 * i / (len(ps) - 1)) for i, p in enumerate(ps)}


def load_colours(loads: Sequence[float]) -> dict[float, Any]:
    ls = sorted({float(v) for v in loads})
    cmap = colormaps["plasma"]
    if len(ls) == 1:
        return {ls[0]: cmap(0.2)}
    return {v: cmap(0.05 + 0.75 * i / (len(ls) - 1)) for i, v in enumerate(ls)}


def draw_table(ax, columns: Sequence[str], rows: Sequence[Sequence[str]],
               widths: Sequence[float], *, fontsize: float = 8.0, title: str = "",
               colours: Sequence[Any] | None = None, bold_first: bool = False,
               align: Sequence[str] | None = None) -> None:
    """A plain text table in an axes (axes coordinates, top down), with rules under the
    header and at the end. ``widths`` are fractions of the axes width."""
    ax.set_axis_off()
    fig = ax.figure
    h_in = ax.get_position().height * fig.get_figheight()
    dy = fontsize * 1.55 / 72 / h_in
    y = 1.0
    if title:
        ax.text(0, y, title, fontsize=fontsize + 1.5, weight="bold", va="top",
                transform=ax.transAxes)
        y -= 1.5 * dy
    xs = np.concatenate([[0.0], np.cumsum(widths)[:-1]])
    align = list(align or ["left"] * len(columns))

    def put(row, yy, weight="normal", colour="black"):
        for x, w, text, al in zip(xs, widths, row, align):
            xx = x + (w - 0.01 if al == "right" else 0.0)
            ax.text(xx, yy, str(text), fontsize=fontsize, va="top", ha=al, weight=weight,
                    color=colour, transform=ax.transAxes, clip_on=False)
    put(columns, y, weight="bold")
    y -= dy
    ax.plot([0, sum(widths)], [y + 0.2 * dy] * 2, color="black", lw=0.6,
            transform=ax.transAxes, clip_on=False)
    for i, row in enumerate(rows):
        put(row, y, weight="bold" if bold_first and i == 0 else "normal",
            colour=(colours[i] if colours is not None else "black"))
        y -= dy
    ax.plot([0, sum(widths)], [y + 0.2 * dy] * 2, color="black", lw=0.4,
            transform=ax.transAxes, clip_on=False)


def rows_fitting(ax_height_in: float, fontsize: float) -> int:
    """How many table rows fit an axes of this height."""
    return max(1, int(ax_height_in / (fontsize * 1.55 / 72)) - 3)


def table_pages(fd, name: str, title: str, subtitle: str, columns: Sequence[str],
                rows: Sequence[Sequence[str]], widths: Sequence[float]) -> list[Page]:
    """``rows`` as one table continued over as many full pages as it needs (none without rows).

    Each page is ``(name, Figure)``, titled ``"title (i/n)"``; ``subtitle`` may name
    ``{first}`` and ``{last}``, the page's first and last row (1-based).
    """
    per_page = rows_fitting(0.82 * PAGE[1], 7)
    starts = range(0, len(rows), per_page)
    pages = []
    for i, start in enumerate(starts):
        part = rows[start:start + per_page]
        fig = new_page(f"{title} ({i + 1}/{len(starts)})",
                       subtitle.format(first=start + 1, last=start + len(part)))
        ax = fig.add_axes((0.04, 0.06, 0.92, 0.82))
        draw_table(ax, columns, part, widths, fontsize=7)
        footer(fig, fd)
        pages.append((name, fig))
    return pages


def text_block(ax, lines: Sequence[str], fontsize: float = 8.5, colour: str = "black"):
    ax.set_axis_off()
    ax.text(0, 1, "\n".join(lines), fontsize=fontsize, va="top", ha="left",
            transform=ax.transAxes, color=colour, linespacing=1.45)


def wrap(head: str, text: str, width: int) -> list[str]:
    """``text`` wrapped to ``width`` after ``head``, continuation lines indented under it."""
    body = textwrap.wrap(text, width) or [""]
    return [head + body[0]] + [" " * len(head) + b for b in body[1:]]
