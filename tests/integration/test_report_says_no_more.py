"""Report pages that say no more than the data: every MF stage point drawn against the variable
its sweep runs over, the friction ellipse only where combined slip was measured, parameter
tables whose heading fits the page and whose intervals tell their ends apart, small errors not
written as 0.000, subtitles above the tables, and a cover that counts the keys as the .tir
does.

The MF rows are the design of tests/integration/test_report_slip_pages.py (the default tyre on a
trailer-like programme: pure sweeps, camber sweeps at fixed slip angles, combined kappa
sweeps at alpha = 3 and 6 deg).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from identify.fit.result import FitResult
from identify.fit.run import FitRun, FitSettings, Provenance
from identify.fit.summary import fmt_pct
from identify.io.fitdir import FitDir, read_fit_dir
from identify.io.tir import read_tir
from identify.report.cover import written_source_counts
from identify.report.fit_pages import fit_pages, interval_digits, interval_title, mf_families
from identify.report.layout import new_page
from identify.report.slip_pages import mf_slip_pages
from identify.report.tables import fmt
from identify.simulate.default_tyre import default_tir_path
from identify.workflows.fit import fit_folder
from tests.integration.test_report_slip_pages import LOADS, PRESSURES, _rows

ROOT = Path(__file__).resolve().parents[2]


def _result(points, form: str) -> FitResult:
    sel = points[points["form"] == form]
    return FitResult("MF", form, "wls", {"PKY1": -30.0}, ("PKY1",), {"PKY1": 0.1},
                     {"PKY1": (-100.0, -1.0)}, (), (), 0.2, {1.9: 0.2, 3.0: 0.2}, 1.0,
                     len(sel), True, "ok", 1, 1, {}, sel["model"].to_numpy(),
                     sel["measured"].to_numpy(), sel["pi_bar"].to_numpy())


@pytest.fixture(scope="module")
def fd() -> FitDir:
    P = read_tir(default_tir_path()).params()
    points = _rows(P)
    from identify.core.tyre import TyreInfo
    tyre = TyreInfo("slip-test", 250000.0, 5000.0, 0.3205, "simulated", "225/50 R17")
    results = tuple(_result(points, f) for f in ("Fy0", "combined", "Mx"))
    run = FitRun(tyre, Provenance("0", "", "", 0, None), results, {}, 61, "slip-test.tir")
    return FitDir(Path("."), run, points, P)


def _markers(fig) -> tuple[int, list[str]]:
    """Measured markers drawn in the left half (the data panels) and those panels' x labels."""
    n, labels = 0, []
    for ax in fig.axes:
        if ax.get_position().x0 >= 0.5 or ax.get_position().y0 < 0.45:
            continue  # residuals, tables
        labels.append(ax.get_xlabel())
        n += sum(len(line.get_xdata()) for line in ax.get_lines()
                 if line.get_linestyle() == "None")
    return n, labels


@pytest.mark.parametrize("form, x_labels", [
    ("Fy0", ["slip angle [deg]", "camber angle [deg]"]),
    ("combined", ["longitudinal slip kappa [-]"]),
    ("Mx", ["camber angle [deg]", "slip angle [deg]"]),
])
def test_every_mf_point_is_drawn_against_its_own_sweep(fd, form, x_labels):
    """No point of an MF stage is left out (the Mx page used to drop most of them) and a
    combined-slip stage is drawn against kappa, not in columns at its slip angles."""
    result = next(r for r in fd.run.results if r.form == form)
    (_, fig), *_ = fit_pages(fd, result)[0]
    n, labels = _markers(fig)
    assert n == len(fd.rows(result))
    assert labels == x_labels


def test_combined_slip_holds_the_slip_angle_as_a_condition(fd):
    result = next(r for r in fd.run.results if r.form == "combined")
    (_, fig), *_ = fit_pages(fd, result)[0]
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "alpha [deg] 3" in texts and "alpha [deg] 6" in texts


def test_mf_families_split_the_rows(fd):
    rows = fd.rows(next(r for r in fd.run.results if r.form == "Mx"))
    fams = mf_families(rows, "gamma_deg")
    assert [c for c, _ in fams] == ["gamma_deg", "alpha_deg"]
    total = sum(m.astype(int) for _, m in fams)
    assert (total == 1).all()  # each point in one family


def test_friction_ellipse_only_where_combined_slip_was_measured(fd):
    """Only positive slip angles (3 and 6 deg) were measured at combined slip, over kappa
    -0.25..0.25: no curve at -3/-6 deg (positive Fy), none beyond the measured slip ratios."""
    pages, _ = mf_slip_pages(fd)
    ellipse = pages[-1]
    assert ellipse.ellipse and ellipse.alphas_deg == (3.0, 6.0)
    P = fd.tir
    for panel in ellipse.panels:
        assert len(panel.curves) == len(LOADS) * 2
        for _fx, fy in panel.curves:
            assert np.max(fy) < 0  # the side of the measured slip angles only
        # the ends of a curve: the model at the measured kappa ends, not beyond
        from identify.model.evaluate import evaluate
        fz, a = LOADS[0], np.deg2rad(3.0)
        end = evaluate(P, np.full(2, fz), np.array([-0.25, 0.25]), np.full(2, a),
                       np.zeros(2), np.full(2, 16.7), p=np.full(2, panel.pi_bar * 1e5),
                       mode=211)
        fx0, _ = panel.curves[0]
        np.testing.assert_allclose([fx0[0], fx0[-1]], end["Fx"], rtol=1e-9)
    assert PRESSURES


def test_parameter_table_heading_is_short():
    kinds = ["LS +/-2.18 s.e. (staged sweep jackknife)", "LS +/-2.19 s.e. (staged sweep "
             "jackknife)", "LS profile (staged sweep jackknife)",
             "LS +/-2.11 s.e. (staged sweep jackknife)", "MCMC 2.5-97.5 %"]
    assert interval_title(kinds) == ("LS +/-2.11-2.19 s.e. (staged sweep jackknife), "
                                     "LS profile (staged sweep jackknife), MCMC 2.5-97.5 %")
    assert interval_title(kinds[:4]) == ("LS +/-2.11-2.19 s.e., LS profile (staged sweep "
                                         "jackknife)")
    assert interval_title(["LS +/-2.04 s.e."] * 3) == "LS +/-2.04 s.e."


def test_interval_ends_are_told_apart():
    lo, hi = 1.019016, 1.019024
    assert fmt(lo, 4) == fmt(hi, 4)  # the premise: 4 digits print 1.019 ... 1.019
    d = interval_digits(lo, hi)
    assert fmt(lo, d) != fmt(hi, d) and d == 7
    assert interval_digits(0.5, 1.5) == 4


def test_small_errors_are_not_written_as_zero():
    assert fmt_pct(0.00016) == "0.00016" and fmt_pct(0.0) == "0.000"
    assert fmt_pct(1.0126) == "1.013" and fmt_pct(123.45) == "123.5"


def test_subtitle_ends_above_the_tables():
    fig = new_page("Data quality", "x " * 160)  # two lines
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    sub = fig.texts[1].get_window_extent(renderer)
    bottom = fig.transFigure.inverted().transform((0, sub.y0))[1]
    assert bottom > 0.88  # the tables and panels of the pages start at 0.88


@pytest.fixture(scope="module")
def small_fit(tmp_path_factory):
    from identify.simulate import simulate_folder
    root = tmp_path_factory.mktemp("cover")
    simulate_folder(read_tir(default_tir_path()).params(), root / "m", seed=2, grid="small",
                    tyre_id="c1")
    run = fit_folder(root / "m", out_root=root / "fits",
                     settings=FitSettings(only=("CFz", "camber")))
    return read_fit_dir(run.fit_dir)


def test_cover_counts_the_keys_as_the_tir_header_does(small_fit):
    counts, zero = written_source_counts(small_fit)
    header = next(line for line in small_fit.tir_path.read_text().splitlines()
                  if "key sources" in line)
    said = dict((k, int(n)) for n, k in re.findall(r"(\d+) ([a-z][a-z. ]*[a-z])",
                                                   header.split(":", 2)[-1].split(";")[0]))
    assert counts == {k: said[k] for k in counts} and set(said) == set(counts)
    assert counts != small_fit.run.source_counts()  # not every key is written for FITTYP 61
    marked = re.search(r"; (\d+) fitted marked", header)
    assert zero == (int(marked.group(1)) if marked else 0)
