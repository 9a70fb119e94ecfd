"""The trailer data-quality pages: what the MF stages had to work with.

From fit.json (``coverage`` and ``data_quality``): the coverage table of the MF stages (loads,
pressures, cambers, slip ranges, identifiable coefficients; a skipped stage with why), the
segments of the continuous runs (levels found per condition, segments per kind, samples each
named filter removed), the channels the fit could not use, and every loading warning with its
count. Nothing is drawn when the fit had no trailer data and no warning.
"""
from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

from identify.io.fitdir import FitDir
from identify.report.layout import Page, draw_table, footer, new_page, table_pages, text_block

__all__ = ["segment_lines", "trailer_pages", "warning_rows"]

_LEVEL_UNITS = {"Fz": ("load", 1e-3, "kN", ".2f"), "p": ("pressure", 1e-3, "kPa", ".1f"),
                "gamma": ("inclination", 57.29577951308232, "deg", ".1f"),
                "Vx": ("speed", 3.6, "kph", ".1f"),
                "alpha": ("set slip angle (slip-ratio sweeps)", 57.29577951308232, "deg",
                          ".1f")}


def _values(values: Sequence[float], scale: float, fmt: str, sep: str = " ") -> str:
    return sep.join(format(v * scale, fmt) for v in values) if values else "-"


def coverage_rows(coverage) -> list[list[str]]:
    """One table row per MF stage."""
    rows = []
    for c in coverage:
        if c.skipped:
            rows.append([c.stage, str(c.points), "skipped", "", "", "", "", ""])
            continue
        n = len(c.identifiable) + len(c.not_identifiable)
        rows.append([c.stage, str(c.points), _values(c.loads, 1e-3, ".1f"),
                     _values(c.pressures, 1e-3, ".0f"), c.camber_text(),
                     _values(c.alpha_deg, 1, ".1f", " .. "), _values(c.kappa, 1, ".2f", " .. "),
                     f"{len(c.identifiable)}/{n}"])
    return rows


def segment_lines(quality: Mapping[str, Any]) -> list[str]:
    """The segmentation as text: runs, sample counts, segments per kind, levels, filters."""
    trailer = quality.get("trailer") or {}
    seg = trailer.get("segmentation")
    turned = trailer.get("mz_turnaround_samples") or 0
    turn = ([f"Mz left out at slip-angle turn-arounds (the rig's steering transient): "
             f"{turned} samples"] if turned else [])
    if not seg:
        return ["No run was segmented (only continuous session logs, TTC .mat/.dat, are).",
                *turn]
    kinds: dict[str, int] = {}
    for s in seg.get("segments") or ():
        kinds[s["kind"]] = kinds.get(s["kind"], 0) + 1
    lines = [f"Runs segmented: {', '.join(trailer.get('segmented_runs') or ())}",
             f"Samples {seg['samples']}, in sweeps {seg['in_sweeps']}, kept {seg['kept']}",
             "Segments: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())),
             "", "Levels found:"]
    for channel, levels in (seg.get("levels") or {}).items():
        what, scale, unit, fmt = _LEVEL_UNITS.get(channel, (channel, 1.0, "", ".4g"))
        text = ", ".join(format(lv["value"] * scale, fmt) for lv in levels) or "none"
        lines += textwrap.wrap(f"{what} [{unit}]: {text}", 70, initial_indent="  ",
                               subsequent_indent="    ")
    lines += ["", "Samples removed per filter:"]
    for f in seg.get("filters") or ():
        state = "" if f["applied"] else f" (not applied: {f['note']})"
        lines.append(f"  {f['name']}: {f['removed']} removed, {f['remaining']} left{state}")
    return lines + ([""] + turn if turn else [])


def warning_rows(quality: Mapping[str, Any]) -> list[list[str]]:
    """One table row per loading warning: run, kind, channels, count of total, action."""
    return [[w.get("run", ""), w.get("kind", ""), ", ".join(w.get("channels") or ())[:40],
             f"{w.get('count', 0)} / {w.get('total', 0)}", w.get("action", ""),
             str(w.get("detail", ""))[:70]]
            for w in quality.get("warnings") or ()]


def trailer_pages(fd: FitDir) -> list[Page]:
    """The trailer data-quality pages (none without coverage and warnings)."""
    run = fd.run
    quality = dict(getattr(run, "data_quality", {}) or {})
    coverage = tuple(getattr(run, "coverage", ()) or ())
    warnings = quality.get("warnings") or []
    if not coverage and not warnings:
        return []
    skipped = [c for c in coverage if c.skipped]
    fig = new_page("Data quality: trailer data",
                   f"{len(coverage) - len(skipped)} of {len(coverage)} MF stages had their data "
                   f"({len(skipped)} skipped); {len(warnings)} loading warning(s), each with "
                   "its count on the next page; the segments of the continuous runs")
    ax = fig.add_axes((0.04, 0.50, 0.92, 0.38))
    if coverage:
        draw_table(ax, ["stage", "points", "loads [kN]", "p [kPa]", "camber [deg]",
                        "alpha [deg]", "kappa", "identifiable"], coverage_rows(coverage),
                   [0.08, 0.07, 0.20, 0.12, 0.15, 0.13, 0.13, 0.09], fontsize=7.5,
                   title="Coverage of the MF stages (before fitting)",
                   align=["left", "right", "left", "left", "left", "left", "left", "right"])
    else:
        ax.set_axis_off()
    lines = ["Skipped stages (their coefficients keep their input/default values):"]
    for c in skipped or ():
        lines += textwrap.wrap(f"{c.stage}: {c.skipped}", 80, initial_indent="  - ",
                               subsequent_indent="    ")
    if not skipped:
        lines.append("  none")
    unusable = (quality.get("trailer") or {}).get("unavailable") or {}
    lines += ["", "Channels the fit could not use:"]
    lines += [f"  - {k}: {v}"[:160] for k, v in unusable.items()] or ["  none"]
    bx = fig.add_axes((0.04, 0.06, 0.44, 0.40))
    text_block(bx, [x for line in lines for x in textwrap.wrap(line, 85) or [""]][:34],
               fontsize=7)
    cx = fig.add_axes((0.52, 0.06, 0.44, 0.40))
    text_block(cx, segment_lines(quality)[:34], fontsize=7)
    footer(fig, fd)
    return [("data quality: trailer", fig)] + table_pages(
        fd, "loading warnings", "Loading warnings",
        "usable data, cleaned while loading; count = samples concerned of the run's samples "
        "(gaps: the number of gaps)", ["run", "kind", "channels", "count", "action", "detail"],
        warning_rows(quality), [0.11, 0.08, 0.2, 0.1, 0.11, 0.4])
