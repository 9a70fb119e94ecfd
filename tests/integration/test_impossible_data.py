"""Values no rig produces are refused; odd but usable files are read (issue 44).

The refusals themselves (a boolean channel, a required channel without a value, forces,
moments, slip ratios, time stamps and time steps no rig logs, CR-only line ends, a NUL byte in
a run file name) are cases of the hostile corpus (tests/integration/test_hostile_corpus.py). Here:
the plausibility ranges admit every real rig (a Formula Student tyre at 0.2 kN, a truck tyre at
50 kN, a TTC file in US units, a slow Flatplank-like log); units in parentheses and axis
names in any case are read; small data fits what it can, or says what is too little, where.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.plausible import BANDS, judge, judge_channel
from identify.fit.coverage import MIN_POINTS
from identify.io.axes import axes_name
from identify.io.common import Problems, split_header_name
from identify.io.trailer.files import channels_to_tidy, read_channels
from identify.io.trailer.quirk_checks import MIN_RUN_SAMPLES
from identify.model.symmetries import sign_patterns
from tests.measurement_cases import TR, trailer_channels, write_csv, write_good_folder

runner = CliRunner()


# ------------------------------------------------------------------ the bands admit real rigs

def _run(tmp_path: Path, ch: dict, units: dict | None = None, header=None):
    path = write_csv(tmp_path / "run.csv", ch, header)
    problems, warnings = Problems(), []
    runs = read_channels(path, units=units, problems=problems)
    frames = [channels_to_tidy(c, problems=problems, warnings=warnings) for c in runs or ()]
    return frames, [str(p) for p in problems.finish()], warnings


def _scaled(n: int, load: float, dt: float, speed: float) -> dict:
    """A cornering sweep scaled to a tyre of nominal load ``load`` [N]: forces and moments
    in proportion (Fy up to 1.2 Fz, Mx up to 0.5 m x Fy at the wheel centre)."""
    ch = trailer_channels(n)
    k = load / 5000.0
    for name in ("FX", "FYW", "FZW", "MYW", "MZW"):
        ch[name] = ch[name] * k
    ch["FYW"] = -1.2 * load * np.tanh(ch["SLIPANGL"] / 0.08)
    ch["MXW"] = 0.5 * ch["FYW"]  # about the wheel centre of a truck tyre: tens of kN m
    ch["RUNTIME"] = np.arange(n) * dt
    ch["LONGVEL"] = np.full(n, speed)
    ch["WHROTSPD"] = np.full(n, speed / 0.31)
    return ch


@pytest.mark.parametrize("load,dt,speed", [(200.0, 0.02, 11.1),   # FSAE, TTC 50 Hz
                                           (50_000.0, 0.001, 22.0),  # truck, 1 kHz
                                           (5000.0, 1.0, 0.05)],  # Flatplank-like slow log
                         ids=["fsae-0.2kN", "truck-50kN", "slow-1Hz"])
def test_real_rigs_pass_without_errors(tmp_path, load, dt, speed):
    frames, problems, warnings = _run(tmp_path, _scaled(200, load, dt, speed))
    assert problems == [] and frames[0] is not None
    assert not [w for w in warnings if w.kind == "plausible" and
                w.channels[0] in ("FX", "FYW", "MXW", "MYW", "MZW", "RUNTIME", "LONGSLIP")]


def test_a_ttc_file_in_us_units_passes(tmp_path):
    ch = _scaled(200, 1500.0, 0.01, 11.1)
    us = {"FX": "lbf", "FYW": "lbf", "FZW": "lbf", "MXW": "ft*lbf", "MYW": "ft*lbf",
          "MZW": "ft*lbf", "INFLPRES": "psi", "LONGVEL": "mph", "SLIPANGL": "deg"}
    lbf, ftlbf = 4.4482216152605, 1.3558179483314
    for name, unit in us.items():
        ch[name] = ch[name] / {"lbf": lbf, "ft*lbf": ftlbf, "psi": 6894.757293168,
                               "mph": 0.44704, "deg": math.pi / 180}[unit]
    frames, problems, _ = _run(tmp_path, ch, units=us)
    assert problems == []
    np.testing.assert_allclose(frames[0]["Fz"].median(), np.median(_scaled(
        200, 1500.0, 0.01, 11.1)["FZW"]), rtol=1e-12)


def test_bands_split_error_and_warning():
    assert judge("force", 5e4) is None and judge("force", -2e5).level == "warning"
    assert judge("force", 2e6).is_error and judge("moment", 2.5e4) is None
    assert judge("time_step", 1e-300).is_error and judge("time_step", 1e-5).level == "warning"
    assert judge("time_step", 1.0) is None and judge("time_step", 3600.1).is_error
    assert judge("time", 1.7e9) is None and judge("time", 1e300).is_error  # Unix time is fine
    assert judge("slip", 1.0) is None and "percent" in judge("slip", 25.0).message
    assert BANDS["force"].error_high == 1e6


def test_a_force_channel_is_judged_on_its_largest_magnitude_with_its_row():
    x = np.zeros(100)
    x[37] = np.nan
    x[60] = -3e6
    finding, row = judge_channel("force", x)
    assert finding.is_error and row == 60 and "-3e+06 N" in finding.message


# ------------------------------------------------------------------ odd but usable files

def test_units_in_parentheses_are_units():
    assert split_header_name("SLIPANGL (deg)") == ("SLIPANGL", "deg")
    assert split_header_name(" INFLPRES ( kPa ) ") == ("INFLPRES", "kPa")
    assert split_header_name("SLIPANGL [deg]") == ("SLIPANGL", "deg")
    assert split_header_name("(deg)") == ("(deg)", None)


def test_a_header_with_units_in_parentheses_is_read(tmp_path):
    ch = trailer_channels()
    ch["SLIPANGL"] = np.degrees(ch["SLIPANGL"])
    header = [f"{k} (deg)" if k == "SLIPANGL" else k for k in ch]
    frames, problems, _ = _run(tmp_path, ch, header=header)
    assert problems == []
    np.testing.assert_allclose(frames[0]["alpha"], trailer_channels()["SLIPANGL"],
                               rtol=1e-12)


def test_axis_names_in_any_case(tmp_path):
    assert axes_name("iso-w") == "ISO-W" and axes_name(" sae ") == "SAE"
    assert axes_name("tydex-c") == "TYDEX-C" and axes_name("ISO") is None
    root = write_good_folder(tmp_path / "f")
    text = (root / "tyre.toml").read_text()
    (root / "tyre.toml").write_text(text.replace('axes = "ISO-W"', 'axes = "iso-w"')
                                    .replace('axes = "SAE"', 'axes = "sae"'))
    result = runner.invoke(app, ["check", str(root)])
    assert result.exit_code == 0, result.output


def test_a_manifest_with_cr_only_line_ends_is_read(tmp_path):
    root = write_good_folder(tmp_path / "f")
    path = root / "tyre.toml"
    path.write_bytes(path.read_bytes().replace(b"\n", b"\r"))
    assert runner.invoke(app, ["check", str(root)]).exit_code == 0


# ------------------------------------------------------------------ small data

def _small_folder(root: Path, n: int, **change) -> Path:
    ch = trailer_channels(n)
    ch.update(change)
    write_csv(root / "trailer" / "c.csv", ch)
    (root / "tyre.toml").write_text(
        '[tyre]\nid = "small"\nnominal_pressure_Pa = 250000\nnominal_load_N = 5000\n'
        'unloaded_radius_m = 0.3205\n\n[[runs]]\nfile = "trailer/c.csv"\nkind = "trailer"\n'
        'test = "cornering"\n')
    return root


def test_one_small_sweep_fits_what_it_can(tmp_path):
    """Before: a stage whose every coefficient the data hold (My on a constant MYW) crashed
    the fit with a traceback (ValueError: cannot reshape array of size 0)."""
    root = _small_folder(tmp_path / "f", 100, MYW=np.zeros(100))
    result = runner.invoke(app, ["fit", str(root), "--out", str(tmp_path / "fits"),
                                 "--no-report"])
    assert result.exit_code == 0, result.output
    assert "MF My (pass 1): skipped, 100 point(s), but no coefficient is identifiable" \
        in result.stdout
    assert (tmp_path / "fits" / "small" / "small.tir").is_file()


def test_two_samples_say_what_is_too_little_where(tmp_path):
    root = _small_folder(tmp_path / "f", 2)
    check = runner.invoke(app, ["check", str(root)])
    assert check.exit_code == 0
    assert (f"warning: {root}/trailer/c.csv: RUNTIME: only 2 usable sample(s): too few for "
            "a sweep") in check.stderr
    result = runner.invoke(app, ["fit", str(root), "--out", str(tmp_path / "fits"),
                                 "--no-report"])
    assert result.exit_code == 2
    (line,) = [x for x in result.stderr.splitlines() if x.startswith("error: ")]
    assert "too little trailer data for any Magic Formula stage in trailer/c.csv (2 " \
           "sample(s))" in line and f"{MIN_POINTS} needed" in line
    assert not (tmp_path / "fits").exists()


def test_the_few_samples_threshold_is_below_a_stage_minimum():
    assert 1 < MIN_RUN_SAMPLES < MIN_POINTS


def test_sign_patterns_of_no_coefficient():
    assert sign_patterns([]).shape == (1, 0)
    assert sign_patterns(["PDY1"]).shape[1] == 1


def test_the_good_folder_has_no_new_warning(tmp_path):
    root = write_good_folder(tmp_path / "f")
    result = runner.invoke(app, ["check", str(root)])
    assert result.exit_code == 0 and "warning" not in result.stderr, result.stderr
    assert (root / TR).is_file()


def test_a_wheel_speed_near_zero_drops_the_channel_without_pythons_text(tmp_path):
    """omega = 1e-310 rad/s: V/omega overflows to inf; the channel is dropped with mfid's
    warning, and no RuntimeWarning of numpy's reaches the user (found by the hypothesis
    readers on a mutated MATLAB v7.3 file)."""
    import warnings as python_warnings

    ch = trailer_channels()
    ch["WHROTSPD"] = np.full(ch["RUNTIME"].size, 1e-310)
    with python_warnings.catch_warnings():
        python_warnings.simplefilter("error")
        frames, problems, warnings = _run(tmp_path, ch)
    assert problems == [] and frames[0] is not None
    assert [w.action for w in warnings if w.channels == ("WHROTSPD",)] == ["channel dropped"]
