"""The .tir an engineer puts into a vehicle model (issue 18): what each key is, and files that
the simplest reader reads.

- every key of a fitted .tir says where its value came from (fitted with its standard error,
  tyre.toml, measured range, default), and fit.json lists the same, typed and round-tripping;
- validity limits are the measured ranges and dimensions come from tyre.toml's size string
  (acceptance 4, on the thesis table);
- the form each nested relation takes is chosen by the data or by ``--form``;
- a fit whose coefficients the data cannot determine is "poorly identified", with its reason
  (acceptance: the CFy relaxation with Kya co-fitted on the thesis' 15 sigma_y points);
- every .tir mfid writes (fit, discover, the bundled default tyre) passes
  tests/naive_tir.py: CRLF line ends, one '=' per data line.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.errors import InputError
from identify.core.tyre_size import parse_tyre_size
from identify.fit.limits import LIMIT_COLUMNS, measured_limits
from identify.fit.run import FitRun
from identify.fit.sources import KINDS, KeySource
from identify.io.folder import load_folder
from identify.io.tir import format_tir, format_value, read_tir, write_tir
from identify.io.tir.write import FIT_DIGITS
from identify.model.parameters import PARAMETERS
from identify.simulate import simulate_folder
from identify.simulate.default_tyre import default_tir_path, write_default_tir
from identify.workflows.fit import (
    FitSettings,
    _base_tir,
    _broken_validity,
    _characteristics,
    _context,
    fit_folder,
)
from identify.workflows.tir_assembly import form_overrides, hold_names, relation_reach
from tests.naive_tir import naive_read

ROOT = Path(__file__).resolve().parents[2]
THESIS = ROOT / "measurements" / "thesis-225-50R17"
runner = CliRunner()
SOURCE = re.compile(r"; (" + "|".join(re.escape(k) for k in KINDS) + r")\b")


@pytest.fixture(scope="module")
def thesis(tmp_path_factory) -> FitRun:
    return fit_folder(THESIS, out_root=tmp_path_factory.mktemp("thesis"),
                      settings=FitSettings())


def _data_lines(path: Path) -> dict[str, str]:
    """key -> its comment, for every data line of a .tir."""
    out = {}
    for line in path.read_bytes().decode("ascii").split("\r\n"):
        s = line.strip()
        if not s or s[0] in "$![":
            continue
        key, _, rest = s.partition("=")
        out[key.strip()] = rest.partition("$")[2]
    return out


def test_every_key_of_the_thesis_tir_says_where_it_came_from(thesis):
    naive_read(thesis.tir_path)
    comments = _data_lines(thesis.tir_path)
    assert comments and all(SOURCE.search(c) for c in comments.values()), [
        k for k, c in comments.items() if not SOURCE.search(c)]
    # fit.json: every table key, typed; the comment is the typed source's text
    doc = json.loads(thesis.json_path.read_text())
    back = FitRun.from_dict(doc)
    assert back.to_dict() == doc and back.key_sources == thesis.key_sources
    assert back.form_choices == thesis.form_choices
    assert set(thesis.key_sources) == {p.name for p in PARAMETERS}
    by_key = {p.tir_key: p.name for p in PARAMETERS}
    for key, comment in comments.items():
        if key in by_key:
            assert comment.rstrip().endswith(thesis.key_sources[by_key[key]].text()
                                             .replace("=", ":")), key
    src = thesis.key_sources
    # fitted keys carry their fit and standard error; placeholders say they are placeholders
    assert src["PCFX1"].kind == "fitted" and src["PCFX1"].detail == "CFx/quadratic_load"
    assert "+/- " in comments["PCFX1"] and math.isfinite(src["PCFX1"].stderr)
    for key in ("PDY1", "PKY1", "QSY1", "YAW_STIFFNESS"):
        assert src[key].kind == "default" and "not identified by these data" in comments[key]
    assert src["FNOMIN"].kind == src["NOMPRES"].kind == "tyre.toml"
    counts = thesis.source_counts()
    assert counts["fitted"] >= 11 and counts["measured range"] == 4
    header = thesis.tir_path.read_text()
    assert re.search(r"key sources \(in each comment\): \d+ default, \d+ fitted", header)


def test_thesis_limits_are_the_measured_ranges_and_dimensions_the_size(thesis):
    tir = read_tir(thesis.tir_path).params()
    points = pd.read_csv(thesis.csv_path)
    assert tir["FZMIN"] == points["Fz_N"].min() == 2000.0
    assert tir["FZMAX"] == points["Fz_N"].max() == 7000.0
    assert tir["PRESMIN"] == pytest.approx(1.9e5) and tir["PRESMAX"] == pytest.approx(3.0e5)
    for lo, hi in LIMIT_COLUMNS:
        kinds = {thesis.key_sources[lo].kind, thesis.key_sources[hi].kind}
        # no slip or camber in the thesis table: those limits are defaults, and say so
        assert kinds == ({"measured range"} if lo in ("FZMIN", "PRESMIN") else {"default"})
    size = parse_tyre_size(thesis.tyre.size)
    assert thesis.tyre.size == "225/50 R17"
    assert (tir["WIDTH"], tir["ASPECT_RATIO"]) == (0.225, 0.5)
    assert tir["RIM_RADIUS"] == 0.2159 == size.rim_radius_m  # written as 0.2159, not 0.21589999...
    assert thesis.key_sources["WIDTH"] == KeySource("tyre.toml", "size 225/50 R17")
    assert tir["UNLOADED_RADIUS"] == 0.3284
    assert thesis.key_sources["UNLOADED_RADIUS"].detail == "unloaded_radius_m"



def test_the_reach_announced_to_the_mf_stages_is_what_the_file_states(thesis):
    """relation_reach, computed before the MF stages from the characteristics, gives the limits
    apply_limits then writes from the relations' fitted points (fit_mf widens its validity
    grid to it)."""
    mset = load_folder(THESIS)
    chars, _, _ = _characteristics(mset, None)
    ctx = _context(mset.manifest.tyre, _base_tir(mset, 61))
    reach = relation_reach(chars, ctx, lambda relation: True)
    assert reach == measured_limits(pd.read_csv(thesis.csv_path))
    assert reach["FZMIN"] == 2000.0 and reach["FZMAX"] == 7000.0
    assert relation_reach(chars, ctx, lambda relation: False) == {}


def test_a_written_file_that_breaks_a_validity_condition_is_a_failure():
    """After the limits are written, the .tir is checked over them (MFeval's coefficientCheck):
    a broken condition goes to run.failed (exit 1), naming the stage, condition and load."""
    tir = {k: v for k, v in read_tir(default_tir_path()).params().items()
           if not isinstance(v, str)}
    points = pd.DataFrame({"pi_bar": [2.5, 2.5], "Fz_N": [1000.0, 7000.0]})
    tir.update(FZMIN=1000.0, FZMAX=7000.0, KPUMIN=-0.15, KPUMAX=0.15, ALPMIN=-0.2, ALPMAX=0.2,
               CAMMIN=-0.1, CAMMAX=0.1)
    assert _broken_validity(tir, points) == ()
    tir.update(PEY1=0.7, PEY2=-0.3)  # Ey = (0.7 + 0.3 * 0.8) * 1.1 > 1 at 1000 N
    (line,) = _broken_validity(tir, points)
    assert line.startswith("tir[validity]: Fy0: Ey <= 1 fails at Fz = 1000 N (margin -")
    assert line.endswith("within the written limits")
    # beyond its bound by round-off, as a stage leaves an active condition: it holds (the
    # fits' FEASIBLE_TOL); a millionth beyond it does not. Ey(1000 N) = (PEY1 + 0.24) 1.1
    edge = 1 / 1.1 - 0.24
    tir.update(PEY1=edge + 1e-12)  # margin -1.1e-12
    assert _broken_validity(tir, points) == ()
    tir.update(PEY1=edge + 1e-6)
    assert len(_broken_validity(tir, points)) == 1


def test_thesis_forms_and_the_poorly_identified_relaxation(thesis):
    # the thesis CFx and CFy curve in load: the quadratic forms are written, with the F test
    forms = {c.relation: c for c in thesis.form_choices}
    assert forms["CFx"].form == "quadratic_load" and forms["CFx"].p_value < 1e-6
    assert forms["CFy"].form == "quadratic_load" and not forms["CFy"].overridden
    tir = read_tir(thesis.tir_path).params()
    fitted = thesis.result("CFx/quadratic_load").parameters["PCFX2"]
    assert tir["PCFX2"] == float(format_value(fitted, FIT_DIGITS)) < 0  # the written digits
    # CFy by relaxation with Kya co-fitted: 7 free coefficients on 15 sigma_y points
    relax = thesis.result("CFy/relaxation")
    assert len(relax.free) == 7 and relax.n_points == 15 and relax.converged
    assert relax.status_text == "poorly identified"
    text = " ".join(relax.reasons)
    assert "PCFY3 = 1 is at its upper bound 1" in text
    assert re.search(r"PCFY3 = 1: 95 % interval \[-\d+\.?\d*, \d+\.?\d*\] is wider than its "
                     r"bounds \[0, 1\]", text)
    assert "correlated" in text
    assert thesis.poorly_identified == ("CFy/relaxation",)
    report = thesis.report()
    assert "poorly identified: 1 of 7 fits" in report
    assert "CFy/relaxation: PCFY3 = 1 is at its upper bound 1" in report
    assert re.search(r"CFy\s+relaxation\s+[\d.]+\s+15\s+poorly identified", report)
    for r in thesis.results:
        if r.name != "CFy/relaxation":
            assert r.status_text == "ok", (r.name, r.reasons)


def test_form_override_and_hold_from_the_command_line(tmp_path):
    res = runner.invoke(app, ["fit", str(THESIS), "--only", "CFx", "--out", str(tmp_path),
                              "--no-report", "--form", "CFx=linear_load", "--hold", "pcfx3"])
    assert res.exit_code == 0, res.output
    run = FitRun.from_dict(json.loads((tmp_path / THESIS.name / "fit.json").read_text()))
    c = run.form_choice("CFx")
    assert c.form == "linear_load" and c.overridden and c.p_value < 1e-6
    assert "form CFx: linear_load (chosen by --form)" in res.stdout
    assert run.key_sources["PCFX1"].detail == "CFx/linear_load"
    for r in run.results:
        assert "PCFX3" not in r.free and r.held == {"PCFX3": "held by --hold"}
        assert r.parameters["PCFX3"] == 0.0 and r.status_text == "ok"
    assert run.key_sources["PCFX3"].kind == "held"
    assert run.settings.forms == ("CFx=linear_load",) and run.settings.hold == ("pcfx3",)
    assert "--form CFx=linear_load --hold pcfx3" in run.provenance.command


@pytest.mark.parametrize("values, message", [
    (["CFx"], "not RELATION=FORM"), (["CFz=mf"], "CFz has no choice of form"),
    (["CFx=cubic"], "unknown form 'cubic' of CFx")])
def test_bad_form_overrides(values, message):
    with pytest.raises(InputError, match=re.escape(message)):
        form_overrides(values)


def test_hold_names_are_checked():
    assert hold_names(["pcfx3,PCFY3", "PCFX3"]) == ("PCFX3", "PCFY3")
    with pytest.raises(InputError, match="NOPE is not a .tir parameter"):
        hold_names(["nope"])
    res = runner.invoke(app, ["fit", str(THESIS), "--hold", "nope", "--no-report"])
    assert res.exit_code == 2 and "--hold" in res.stderr and "NOPE" in res.stderr


def test_key_source_round_trip_and_text():
    s = KeySource.fitted("MF/Fy0 (trailer)", 0.0123)
    assert KeySource.from_dict(s.to_dict()) == s and s.supplied_by == "MF/Fy0"
    assert s.text() == "fitted MF/Fy0 (trailer) +/- 0.0123"
    assert KeySource.from_dict("CFx/linear_load") == KeySource.fitted("CFx/linear_load")
    assert KeySource.default().text() == "default, not identified by these data"
    nan = KeySource("measured range", "of the fitted data (CFx)")
    assert json.dumps(nan.to_dict()) and KeySource.from_dict(nan.to_dict()).text() == nan.text()
    with pytest.raises(ValueError, match="unknown key-source kind"):
        KeySource("guessed")


# ----- every writer's .tir reads with the simplest reader ------------------------------------

def test_bundled_default_tyre_is_its_writers_output(tmp_path):
    bundled = default_tir_path()
    naive = naive_read(bundled)
    again = write_default_tir(tmp_path / "default.tir")
    assert again.read_bytes() == bundled.read_bytes()  # regenerated through its writer
    assert naive["DIMENSION"]["WIDTH"] == 0.225 and naive["MODEL"]["FITTYP"] == 61.0


def test_discover_tir_reads_with_the_simplest_reader(tmp_path):
    rows = ["quantity,pi_bar,Fz_N,value,unit"]
    rng = np.random.default_rng(0)
    for p in (1.9, 2.2, 2.5, 2.7, 3.0):
        for fz in (2000.0, 4000.0, 6000.0):
            c = 2.2e5 * (1 + 0.25 * (fz - 5e3) / 5e3) * (1 + 0.2 * (p - 2.5) / 2.5)
            rows.append(f"CFx,{p},{fz},{c * (1 + 0.005 * rng.standard_normal()):.3f},N/m")
    folder = tmp_path / "tyre"
    folder.mkdir()
    (folder / "characteristics.csv").write_text("\n".join(rows) + "\n")
    (folder / "tyre.toml").write_text(
        '[tyre]\nid = "tyre"\nnominal_pressure_Pa = 250000\nnominal_load_N = 5000\n'
        'unloaded_radius_m = 0.32\nsize = "225/50 R17"\n\n[[runs]]\nid = "t"\n'
        'file = "characteristics.csv"\nkind = "characteristics"\ntest = "any"\n'
        'axes = "ISO-W"\n')
    res = runner.invoke(app, ["discover", str(folder), "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    naive = naive_read(tmp_path / "out" / "tyre.tir")
    assert naive["STRUCTURAL"]["PCFX3"] != 0.0


def test_fit_tir_is_plain_ascii_whatever_the_names(tmp_path):
    # a tyre id and an input folder with accented letters: the .tir header names them without
    # accents, and the file stays plain ASCII (FILE_FORMAT : ASCII) with CRLF line ends
    folder = tmp_path / "Messungen-Reifen-\u00e4"
    folder.mkdir()
    for f in THESIS.iterdir():
        if f.is_file():
            (folder / f.name).write_bytes(f.read_bytes())
    toml = folder / "tyre.toml"
    toml.write_text(toml.read_text(encoding="utf-8").replace(
        'id = "thesis-225-50R17"', 'id = "Stra\u00dfenreifen-\u00e9t\u00e9"'), encoding="utf-8")
    run = fit_folder(folder, out_root=tmp_path / "out", settings=FitSettings(only=("CFx",)))
    naive = naive_read(run.tir_path)
    assert naive["MODEL"]["FITTYP"] == 61.0
    header = run.tir_path.read_bytes().decode("ascii")
    assert "from Stra?enreifen-ete (" in header


def test_writer_keeps_to_ascii_and_one_equals_sign(tmp_path):
    path = write_tir(tmp_path / "w.tir", {"PKY1": -21.5}, fittyp=62,
                     comment_lines=["inputs: M\u00fcnchen/run=1.csv", "\u03bc = 1.1 \u2713"],
                     sources={"PKY1": "fitted K\u00e4fer = 3"})
    naive = naive_read(path)
    assert naive["LATERAL_COEFFICIENTS"]["PKY1"] == -21.5 and naive["MODEL"]["FITTYP"] == 62.0
    text = path.read_bytes().decode("ascii")
    assert "inputs: Munchen/run:1.csv" in text and "? : 1.1 ?" in text
    assert "fitted Kafer : 3" in text


NUMERIC = [p.name for p in PARAMETERS if not isinstance(p.default, str) and p.name != "FITTYP"]
FREE_TEXT = st.text(st.characters(blacklist_categories=("Cs",)), max_size=40)


@settings(max_examples=60, deadline=None)
@given(values=st.dictionaries(st.sampled_from(NUMERIC),
                              st.floats(allow_nan=False, allow_infinity=False), max_size=30),
       sources=st.dictionaries(st.sampled_from(NUMERIC), FREE_TEXT, max_size=10),
       comments=st.lists(FREE_TEXT, max_size=4),
       unknown=st.dictionaries(st.from_regex(r"[A-Z]{2,8}\.[A-Z][A-Z0-9_]{0,10}", fullmatch=True),
                               st.floats(allow_nan=False, allow_infinity=False), max_size=4),
       fittyp=st.sampled_from((61, 62)))
def test_any_written_tir_reads_with_the_simplest_reader(tmp_path_factory, values, sources,
                                                        comments, unknown, fittyp):
    # every .tir mfid writes (fit, discover, the default tyre) is format_tir's text: whatever
    # the values, source texts, provenance lines (file names, ids, commands) and keys carried
    # over from an input file, the naive reader reads every value back exactly
    path = tmp_path_factory.mktemp("w") / "any.tir"
    known = {f"{sec}.{key}" for p in PARAMETERS for sec, key in [(p.section, p.tir_key)]}
    unknown = {k: v for k, v in unknown.items() if k not in known and k.split(".")[1] not in
               {p.tir_key for p in PARAMETERS}}
    path.write_bytes(format_tir(values, fittyp=fittyp, comment_lines=comments,
                                unknown=unknown, sources=sources).encode("ascii"))
    naive = naive_read(path)
    by_name = {p.name: p for p in PARAMETERS}
    for name, value in values.items():
        p = by_name[name]
        if p.tir_key in naive.get(p.section, {}):
            assert naive[p.section][p.tir_key] == value, name
    for dotted, value in unknown.items():
        section, key = dotted.split(".")
        assert naive[section][key] == value, dotted


def test_relation_with_one_form_per_mode_writes_every_mode(tmp_path):
    # the sidewall relation fits one scaling form per ring mode: all six go into the .tir (a
    # small simulated folder: its eigenfrequency table has every mode at two pressures, and
    # the scaling forms are what the claim is about, not the sample's full grid)
    folder = tmp_path / "small"
    simulate_folder(read_tir(default_tir_path()).params(), folder, seed=1, grid="small")
    run = fit_folder(folder, out_root=tmp_path / "fits", settings=FitSettings(only=("sidewall",)))
    for mode in ("X", "Y", "Z", "THETA", "GAMMA", "PSI"):
        src = run.key_sources[f"F_{mode}"]
        assert src.kind == "fitted" and src.detail == f"sidewall/scaling_{mode.lower()}", src
    assert run.key_sources["PRESMIN"].kind == "measured range"
    assert not run.form_choices
    naive_read(run.tir_path)
