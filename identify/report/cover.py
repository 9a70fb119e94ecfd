"""The cover page (tyre, provenance, settings, every fit with its total thesis error) and the
appendix of input files when the cover cannot list them all."""
from __future__ import annotations

from identify.core.errors import InputError
from identify.core.jsonsafe import json_safe
from identify.core.version import __version__
from identify.fit.sources import FITTED, KINDS
from identify.fit.status import OK, POOR_FIT
from identify.io.fitdir import FitDir
from identify.io.tir import read_tir
from identify.io.tir.write import ZERO_MARK, holds_zero
from identify.report import tables as T
from identify.report.layout import (
    ORANGE,
    PAGE,
    RED,
    Page,
    draw_table,
    footer,
    new_page,
    rows_fitting,
    wrap,
)


def written_source_counts(fd: FitDir) -> tuple[dict[str, int], int]:
    """How many keys of the written .tir came from each kind of source, counted as its header
    counts them (the keys the file holds: a key left out for its FITTYP at its default is not
    in it), and how many fitted keys are marked :data:`ZERO_MARK`. Without a readable .tir:
    every key of fit.json's sources, and no mark counted."""
    sources = fd.run.key_sources
    try:
        tir = read_tir(fd.tir_path)
    except (InputError, OSError):
        return fd.run.source_counts(), 0
    absent = set(tir.defaults_used)
    counts: dict[str, int] = {}
    zero = 0
    for key, src in sources.items():
        if key in absent:
            continue
        counts[src.kind] = counts.get(src.kind, 0) + 1
        zero += src.kind == FITTED and holds_zero(tir.values.get(key, ""), src.stderr)
    order = {k: i for i, k in enumerate(KINDS)}
    return dict(sorted(counts.items(), key=lambda kv: order.get(kv[0], len(order)))), zero


def cover(fd: FitDir) -> list[Page]:
    """The cover page (and continuation pages when the summary table is long)."""
    tyre, prov = fd.tyre, fd.provenance
    source = tyre.source or "unknown"
    real = {"measured": "real (measured)", "simulated": "simulated"}.get(source, source)
    fig = new_page(f"Fit report: {fd.tyre_id}",
                   "Magic Formula with inflation pressure: pressure relations and MF "
                   "coefficients identified by mfid")
    # the settings as fit.json records them (JSON values: a list for "only")
    settings = json_safe(prov.settings.to_dict()) if prov.settings is not None else {}
    inputs = prov.inputs
    setting_text = ", ".join(f"{k}={v}" for k, v in settings.items())
    lines = [
        f"tyre              {fd.tyre_id}",
        f"data              {real}",
        (f"nominal           {T.fmt(tyre.nominal_pressure_Pa / 1e5)} bar, "
         f"{T.fmt(tyre.nominal_load_N)} N"),
        (f"fitted            {prov.created_utc or 'n/a'} (UTC), mfid "
         f"{prov.mfid_version or 'n/a'}"),
        f"report            mfid {__version__}",
        f".tir              {fd.tir_path.name} (FITTYP {fd.run.fittyp})",
        f"seed              {prov.seed}",
    ]
    lines += wrap("settings          ", setting_text, 70)
    lines += wrap("command           ", prov.command or "n/a", 70)
    counts, zero = written_source_counts(fd)
    if counts:
        text = ", ".join(f"{n} {k}" for k, n in counts.items())
        if zero:
            text += f"; {zero} fitted marked {ZERO_MARK}"
        lines += wrap(".tir key sources  ", text, 70)
    for c in fd.run.form_choices:
        how = "chosen by --form" if c.overridden else "chosen by the data"
        lines.append(f"form {c.relation:<13}{c.form} ({how}, F test p = {c.p_value:.2g})")
    poor = fd.run.poorly_identified
    if poor:
        lines += wrap("poorly identified ", f"{len(poor)}: " + ", ".join(poor), 70)
    ax = fig.add_axes((0.04, 0.55, 0.50, 0.34))
    ax.set_axis_off()
    ax.text(0, 1, "\n".join(lines), fontsize=7.5, family="monospace", va="top",
            transform=ax.transAxes, linespacing=1.35)
    files = [f"input files ({len(inputs)}), SHA-256 (first 16 hex digits):"]
    shown = inputs if len(inputs) <= 12 else inputs[:8]
    width = max((len(_short_path(i.path, fd)) for i in shown), default=0)
    for i in shown:  # whole names: a cut name is no reference
        files.append(f"  {_short_path(i.path, fd):<{width}} {i.sha256[:16]}")
    if len(shown) < len(inputs):
        by_dir: dict[str, int] = {}
        for i in inputs[len(shown):]:
            rel = _short_path(i.path, fd)
            d = rel.rsplit("/", 1)[0] + "/" if "/" in rel else "./"
            by_dir[d] = by_dir.get(d, 0) + 1
        files.append("  ... and " + ", ".join(f"{n} more in {d}" for d, n in by_dir.items()))
        files.append("  (every file and its checksum: appendix)")
    fax = fig.add_axes((0.56, 0.55, 0.40, 0.34))
    fax.set_axis_off()
    longest = max(len(f) for f in files)
    fax.text(0, 1, "\n".join(files), fontsize=min(7.0, 7.0 * 80 / max(longest, 1)),
             family="monospace", va="top", transform=fax.transAxes, linespacing=1.35)
    if fd.failed:
        fig.text(0.04, 0.565, "FIT FAILED: " + "; ".join(fd.failed)[:170], fontsize=9,
                 color=RED, weight="bold", va="top")
    rows = fd.run.summary_rows()
    fs = 8.0
    height_in = 0.49 * PAGE[1]
    while fs > 5.0 and rows_fitting(height_in, fs) < len(rows):
        fs -= 0.5
    per = rows_fitting(height_in, fs)
    parts = T.chunks(rows, per)
    pages = [("cover", fig)]
    for i, part in enumerate(parts):
        if i:
            fig = new_page(f"Fit report: {fd.tyre_id} (summary continued)")
        tax = fig.add_axes((0.04, 0.05, 0.92, 0.49 if i == 0 else 0.82))
        table = [[r.relation, r.form, T.fmt_pct(r.error_total_pct), str(r.n_points),
                  r.status_cell, r.tir_cell, r.key_coefficients[:90]] for r in part]
        draw_table(tax, ["relation", "form", "total error %", "points", "status",
                         "-> .tir", "key coefficients"], table,
                   [0.07, 0.11, 0.08, 0.05, 0.12, 0.05, 0.52], fontsize=fs,
                   title="Every fit: total thesis error (mean of the per-pressure errors); "
                         "x* = the form the data (or --form) chose",
                   colours=[RED if r.status_cell in ("FAILED", POOR_FIT)
                            else ORANGE if r.status_cell != OK else "black" for r in part],
                   align=["left", "left", "right", "right", "left", "left", "left"])
        if not rows:
            tax.text(0, 0.8, "no fits", fontsize=9, transform=tax.transAxes)
        footer(fig, fd, "thesis metric: eps = 100 sqrt(sum (model - meas)^2 / sum meas^2) per "
                        "pressure; total = mean over pressures")
        if i:
            pages.append(("cover (continued)", fig))
    return pages


def _short_path(path: str, fd: FitDir) -> str:
    text = path
    src_root = None  # paths relative to the measurement folder where possible
    for inp in fd.provenance.inputs:
        p = inp.path
        if p.endswith("tyre.toml"):
            src_root = p[: -len("tyre.toml")]
    if src_root and text.startswith(src_root):
        return text[len(src_root):]
    return text if len(text) <= 60 else "..." + text[-57:]


def inputs_appendix(fd: FitDir) -> list[Page]:
    """Every input file and its SHA-256 (only when the cover could not list them all)."""
    inputs = fd.provenance.inputs
    if len(inputs) <= 12:
        return []
    per_col, cols = 64, 2
    pages = []
    for start in range(0, len(inputs), per_col * cols):
        chunk = inputs[start:start + per_col * cols]
        fig = new_page("Appendix: input files and SHA-256",
                       f"files {start + 1}-{start + len(chunk)} of {len(inputs)}")
        for c in range(cols):
            part = chunk[c * per_col:(c + 1) * per_col]
            if not part:
                continue
            ax = fig.add_axes((0.04 + 0.47 * c, 0.06, 0.45, 0.83))
            ax.set_axis_off()
            width = max(len(_short_path(i.path, fd)) for i in part)
            ax.text(0, 1, "\n".join(f"{_short_path(i.path, fd):<{width}} {i.sha256[:16]}"
                                    for i in part),
                    fontsize=5.6, family="monospace", va="top", transform=ax.transAxes,
                    linespacing=1.25)
        footer(fig, fd)
        pages.append(("inputs", fig))
    return pages

