"""Issue 18 acceptance 8 on the bundled sample (``make trials``; a full fit, minutes): the
report ``mfid fit measurements/sample-225-50R17`` writes opens with an outline listing every
page; the MF slip pages share one y-scale across their pressure panels and have one legend
entry per load; every fit page's legend has one entry per pressure and per load/camber level.

``MFID_SAMPLE_FITDIR`` (a fit directory of the sample already written by ``mfid fit``, e.g. one
kept by ``bench/truth_compare.py truth --sample --keep DIR``) skips the fit.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader
from typer.testing import CliRunner

from identify.cli.app import app
from identify.io.fitdir import read_fit_dir
from identify.report.fit_pages import fit_pages
from identify.report.pdf import bookmark_titles, write_report
from identify.report.slip_pages import mf_slip_pages, slip_pages

SAMPLE = Path(__file__).resolve().parents[2] / "measurements" / "sample-225-50R17"
pytestmark = pytest.mark.trials
SLIP_TITLES = ["MF Fy - alpha", "MF Fx - kappa", "MF Mz - alpha", "MF Mx - gamma",
               "MF Friction ellipse"]


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    """(fit directory, the report mfid fit wrote or one rebuilt from the kept directory)."""
    out = tmp_path_factory.mktemp("sample")
    kept = os.environ.get("MFID_SAMPLE_FITDIR")
    if kept:
        fit_dir = Path(kept)
        report = write_report(fit_dir, out / "sample.pdf").path
    else:
        res = CliRunner().invoke(app, ["fit", str(SAMPLE), "--out", str(out / "fits"),
                                       "--reports", str(out / "reports")])
        assert res.exit_code == 0, res.output
        fit_dir = out / "fits" / SAMPLE.name
        report = out / "reports" / f"{SAMPLE.name}.pdf"
    return read_fit_dir(fit_dir), report


def test_sample_report_opens_with_an_outline_of_every_page(sample, tmp_path):
    fd, pdf = sample
    reader = PdfReader(pdf)
    outline = reader.outline
    assert reader.page_mode == "/UseOutlines"
    assert len(outline) == len(reader.pages) > 10
    assert [reader.get_destination_page_number(o) for o in outline] == \
        list(range(len(reader.pages)))
    titles = [o.title for o in outline]
    # the same directory rebuilds the same pages, titled as the bookmarks
    again = write_report(fd, tmp_path / "again.pdf")
    assert titles == bookmark_titles(list(again.pages))
    assert titles[0] == "cover" and "data quality" in titles
    assert [t for t in titles if t.startswith("MF ") and t in SLIP_TITLES] == SLIP_TITLES
    assert len(set(titles)) == len(titles)
    # every fit has its page(s): its relation and form name a bookmark
    for fit in fd.results:
        assert any(fit.relation in t and fit.form in t for t in titles), (fit.name, titles)


def test_sample_slip_pages_share_y_limits_and_list_each_load_once(sample):
    fd, _ = sample
    pages, notes = mf_slip_pages(fd)
    assert [f"MF {p.title.split(' (')[0]}" for p in pages] == SLIP_TITLES, notes
    pressures = sorted({round(float(p), 2) for p in fd.mf_rows()["pi_bar"]})
    for (title, fig), sp in zip(slip_pages(fd, pages), pages):
        axes = [ax for ax in fig.axes if ax.get_title().endswith(" bar")]
        assert [float(ax.get_title().split()[0]) for ax in axes] == pressures, title
        assert len({ax.get_ylim() for ax in axes}) == 1, title
        lo, hi = axes[0].get_ylim()
        for panel in sp.panels:  # every curve and point inside the shared range
            for _, y in panel.curves + panel.points:
                y = np.asarray(y, float)
                y = y[np.isfinite(y)]
                assert y.size == 0 or (lo <= y.min() and y.max() <= hi), title
        labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
        loads = [lab for lab in labels if lab.startswith("Fz ")]
        assert loads == [f"Fz {v:.0f} N" for v in sp.panels[0].loads] and len(loads) >= 2
        assert len(set(labels)) == len(labels), (title, labels)
        if sp.ellipse:
            assert len({ax.get_xlim() for ax in axes}) == 1
            assert "measured (combined slip)" in labels
            assert all(f"alpha +/-{a:.1f} deg" in labels for a in sp.alphas_deg)
        else:
            assert labels[-1] == "measured"


def test_sample_fit_pages_have_one_legend_entry_per_level(sample):
    fd, _ = sample
    checked = 0
    for fit in fd.results:
        pages, _ = fit_pages(fd, fit)
        rows = fd.rows(fit)
        pressures = sorted({round(float(p), 4) for p in rows["pi_bar"]})
        ax = pages[0][1].axes[0]
        legend = ax.get_legend()
        if legend is None:
            continue
        labels = [t.get_text() for t in legend.get_texts()]
        assert len(set(labels)) == len(labels), (fit.name, labels)
        assert [lab for lab in labels if lab.endswith(" bar")] == \
            [f"{p:g} bar" for p in pressures], fit.name
        checked += 1
        if fit.relation == "MF":
            # at most a handful of level entries: one per load or camber level, never one
            # per sweep
            assert len(labels) - len(pressures) <= 12, (fit.name, labels)
    assert checked >= len(fd.results) // 2
