"""TTC files as real sessions write them, unlike the generator's (issue 14): other spellings of
channel names and units, variables that are not channels, older rounds without some channels,
and .dat text with other line endings, separators and encodings. Each is read (with a warning
and its count where something is odd) or refused in one line naming the file and channel."""
from __future__ import annotations

import gzip

import numpy as np
import pytest
import scipy.io
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.errors import InputError
from identify.io.common import Problems
from identify.io.trailer.files import channels_to_tidy, read_channels, read_trailer
from identify.io.ttc.files import TTC_CHANNELS, read_ttc
from tests.ttc_cases import _small_channels, import_refused, read_clean


def _mat(path, ch, names=None, units=None, extra=None, shape=lambda v: v.reshape(-1, 1)):
    """A v5 .mat of channels ``ch`` whose channel struct lists ``names`` and ``units``."""
    names = list(ch) if names is None else names
    units = [TTC_CHANNELS[k].si_unit for k in ch] if units is None else units
    content = {k: shape(np.asarray(v)) for k, v in ch.items()}
    content["channel"] = {"name": np.array(names, dtype=object),
                          "units": np.array(units, dtype=object)}
    content["tireid"] = "small"
    content.update(extra or {})
    scipy.io.savemat(path, content, format="5")
    return path



def _refused(path):
    """The lines of a file read_ttc refuses (it returns None)."""
    problems = Problems()
    assert read_ttc(path, problems) is None
    return [str(p) for p in problems.finish()]


@pytest.mark.parametrize("names", [
    [n.lower() for n in _small_channels()],               # another case
    [n + "   " for n in _small_channels()],               # padded (a char matrix's rows)
    [" " + n.lower() + " " for n in _small_channels()],
], ids=["lower", "padded", "lower-padded"])
def test_channel_struct_names_in_another_case_or_padded(tmp_path, names):
    ch = _small_channels()
    run = read_clean(_mat(tmp_path / "B1run1.mat", ch, names,
                     [TTC_CHANNELS[k].si_unit + "  " for k in ch]))
    assert run.units == {k: TTC_CHANNELS[k].si_unit for k in ch}
    np.testing.assert_array_equal(run.data["FZ"], ch["FZ"])


def test_channel_struct_as_a_char_matrix(tmp_path):
    """MATLAB's char(...) of the names: one row per name, padded with blanks to the longest."""
    ch = _small_channels()
    width = max(map(len, ch))
    unit_width = max(len(TTC_CHANNELS[k].si_unit) for k in ch)
    path = tmp_path / "B1run1.mat"
    content = {k: v.reshape(-1, 1) for k, v in ch.items()}
    content["channel"] = {"name": np.array([k.ljust(width) for k in ch]),
                          "units": np.array([TTC_CHANNELS[k].si_unit.ljust(unit_width)
                                             for k in ch])}
    scipy.io.savemat(path, content, format="5")
    assert read_clean(path).units["MZ"] == "N-m"


def test_variables_in_lower_case_are_the_ttc_channels(tmp_path):
    ch = {k.lower(): v for k, v in _small_channels().items()}
    run = read_clean(_mat(tmp_path / "B1run1.mat", ch, list(ch),
                     [TTC_CHANNELS[k.upper()].si_unit for k in ch]))
    assert set(run.data) == set(_small_channels()) and run.units["P"] == "kPa"


def test_variables_that_are_not_channels_are_left_out(tmp_path):
    """A scalar (a rim width), a vector of another length, a matrix, a cell array, a struct
    and a string next to the channels: none is a channel, none stops the import."""
    ch = _small_channels()
    extra = {"RIMWIDTH": 7.0, "calib": np.arange(5.0), "gains": np.eye(3),
             "notes": np.array(["a", "bb"], dtype=object), "meta": {"rig": "belt", "k": 3.0},
             "comment": "hello", "nothing": np.zeros((0, 0))}
    run = read_clean(_mat(tmp_path / "B1run1.mat", ch, extra=extra))
    assert set(run.data) == set(ch)


def test_a_listed_channel_of_another_length_is_left_out_and_a_required_one_is_missed(
        tmp_path):
    ch = _small_channels()
    ch["FY"] = ch["FY"][:150]
    path = _mat(tmp_path / "B1run1.mat", ch)
    run = read_clean(path)
    assert "FY" not in run.data and "FX" in run.data
    with pytest.raises(InputError) as err:
        read_trailer(path)
    assert str(err.value) == f"{path}: FY: missing required channel"


def test_dat_names_in_another_case_or_padded(tmp_path):
    ch = _small_channels()
    path = tmp_path / "B1run1.dat"
    rows = "\n".join("\t".join(f"{ch[k][i]:g}" for k in ch) for i in range(200))
    path.write_text("title\n" + "\t".join(f" {k.lower()} " for k in ch) + "\n"
                    + "\t".join(TTC_CHANNELS[k].si_unit for k in ch) + "\n" + rows + "\n")
    run = read_clean(path)
    assert set(run.data) == set(ch) and run.units["FZ"] == "N"


def _dat_lines(ch=None, units=None, sep="\t"):
    ch = _small_channels() if ch is None else ch
    units = {k: TTC_CHANNELS[k].si_unit for k in ch} | dict(units or {})
    rows = [sep.join(f"{ch[k][i]:.6g}" for k in ch) for i in range(len(ch["ET"]))]
    return ["B1 run 1", sep.join(ch), sep.join(units[k] for k in ch), *rows]


def _write(path, lines, end="\n", encoding="utf-8", last=True):
    path.write_bytes((end.join(lines) + (end if last else "")).encode(encoding))
    return path


def _tidy(path):
    (ch,) = read_channels(path, problems=Problems(strict=True))
    warnings = []
    return ch, channels_to_tidy(ch, warnings=warnings), warnings


def test_dat_title_in_windows_1252(tmp_path):
    lines = _dat_lines()
    lines[0] = "Prüfstand 18° run"
    run = read_clean(_write(tmp_path / "B1run1.dat", lines, encoding="cp1252"))
    assert run.attrs["title"] == "Prüfstand 18° run" and run.data["ET"].size == 200


@pytest.mark.parametrize("sep,end", [(",", "\n"), ("\t", "\r\n")], ids=["comma", "crlf"])
def test_dat_comma_separated_or_crlf(tmp_path, sep, end):
    ch = _small_channels()
    run = read_clean(_write(tmp_path / "B1run1.dat", _dat_lines(sep=sep), end=end))
    np.testing.assert_allclose(run.data["FY"], ch["FY"], rtol=1e-5, atol=0)  # %.6g: 5e-6


def test_dat_trailing_tab_on_the_data_rows_only(tmp_path):
    """With NaN cells in the data (one in the last column, which sends the reader to count
    fields per row)."""
    lines = _dat_lines()
    lines[3:] = [line + "\t" for line in lines[3:]]
    lines[10] = "\t".join(["NaN" if i == 7 else c for i, c in enumerate(lines[10].split("\t"))])
    lines[20] = "\t".join(["NaN" if i == 11 else c for i, c in enumerate(lines[20].split("\t"))])
    run = read_clean(_write(tmp_path / "B1run1.dat", lines))
    assert np.isnan(run.data["FY"][7]) and np.isfinite(run.data["FY"]).sum() == 199


@pytest.mark.parametrize("cut, fields", [
    (lambda row: "\t".join(row.split("\t")[:5]), 5),
    # after the '-' of FZ's -1000 (copied while the logger wrote it); before, the whole file
    # was refused: 'not tab-separated numbers (could not convert string to float: '-')'
    (lambda row: row[:row.index("-") + 1], 9),
], ids=["between-fields", "after-a-sign"])
def test_dat_cut_inside_its_last_row_is_a_warning_and_the_row_is_dropped(tmp_path, cut,
                                                                          fields):
    lines = _dat_lines()
    lines[-1] = cut(lines[-1])
    path = _write(tmp_path / "B1run1.dat", lines, last=False)
    ch, frame, warnings = _tidy(path)
    assert len(frame) == 199
    (cut_row,) = [w for w in warnings if w.kind == "truncated"]
    assert str(cut_row) == (f"{path}:203: ET: the last row stops after {fields} of 12 fields "
                            "(the file ends inside it) (1 of 200 samples); row dropped")


@pytest.mark.parametrize("last,end", [(None, True), ("END", False)],
                         ids=["ends-with-newline", "not-a-number-start"])
def test_dat_with_a_bad_last_row_is_still_one_line(tmp_path, last, end):
    """Not what a cut leaves: a file that ends with a newline (its '-' is bad data), or a last
    row that is no start of a number."""
    lines = _dat_lines()
    lines[-1] = last or lines[-1][:lines[-1].index("-") + 1]
    path = _write(tmp_path / "B1run1.dat", lines, last=end)
    assert _refused(path) == [
        f"{path}:4: data below the header are not tab-separated numbers (could not convert "
        f"string to float: '{last or '-'}')"]


def test_dat_whose_rows_are_wider_than_its_header_is_one_line(tmp_path):
    """A channel name missing from line 2 (13 values a row under 12 names). Before: read
    with the 13th value of every row dropped (pandas' index_col=False, a ParserWarning
    only), so each channel after the missing name got its neighbour's values."""
    lines = _dat_lines()
    lines[3:] = [line + "\t7" for line in lines[3:]]
    path = _write(tmp_path / "B1run1.dat", lines)
    assert _refused(path)[0] == (
        f"{path}:4: ragged row: 13 fields, the header has 12")


def test_dat_short_row_inside_the_data_is_still_one_line(tmp_path):
    lines = _dat_lines()
    lines[50] = "\t".join(lines[50].split("\t")[:5])
    path = _write(tmp_path / "B1run1.dat", lines)
    assert _refused(path) == [
        f"{path}:51: ragged row: 5 fields, the header has 12"]


@pytest.mark.parametrize("row, extra", [(50, ""), (3, "\t7")], ids=["short", "wider"])
def test_dat_with_cr_only_line_ends_and_a_ragged_row_is_one_line(tmp_path, row, extra):
    """A file saved with a lone CR ending each line (classic Mac OS). Before, the field count
    read it as one line: a short row was kept with NaN, a wider one lost its last field."""
    lines = _dat_lines()
    lines[row] = "\t".join(lines[row].split("\t")[:5]) if not extra else lines[row] + extra
    path = _write(tmp_path / "B1run1.dat", lines, end="\r")
    assert _refused(path)[0] == (
        f"{path}:{row + 1}: ragged row: {13 if extra else 5} fields, the header has 12")


def test_dat_with_cr_only_line_ends_cut_inside_its_last_row_drops_it(tmp_path):
    lines = _dat_lines()
    lines[-1] = lines[-1][:lines[-1].index("-") + 1]
    path = _write(tmp_path / "B1run1.dat", lines, end="\r", last=False)
    ch, frame, warnings = _tidy(path)
    assert len(frame) == 199
    assert [w.kind for w in warnings].count("truncated") == 1


def test_dat_gzipped_without_a_gz_suffix_is_read(tmp_path):
    """Gzip data in a file named .dat: the header was read decompressed (open_text tells gzip
    by its magic bytes) and the rows below it as the compressed bytes (pandas by the suffix),
    'not tab-separated numbers (could not convert string to float: ...)'."""
    ch = _small_channels()
    path = tmp_path / "B1run1.dat"
    path.write_bytes(gzip.compress(("\n".join(_dat_lines()) + "\n").encode()))
    run = read_clean(path)
    np.testing.assert_allclose(run.data["FY"], ch["FY"], rtol=1e-5, atol=0)  # %.6g: 5e-6


def test_dat_gz_cut_short_is_one_line_not_an_abort(tmp_path):
    """A gzipped .dat copied before its compressor finished: the header reads, the data end
    inside the stream. Before, pandas' EOFError left the reader, and the command line (click
    takes EOFError for Ctrl-D) printed 'Aborted.' and exited 1 without naming the file."""
    data = gzip.compress(("\n".join(_dat_lines()) + "\n").encode())
    path = tmp_path / "B1run1.dat.gz"
    path.write_bytes(data[:len(data) * 2 // 3])
    assert import_refused([path], tmp_path / "out") == [
        f"error: {path}: cannot read file: Compressed file ended before the end-of-stream "
        "marker was reached"]


@pytest.mark.parametrize("unit,si", [("C", 303.15), ("F", 273.15 + 5 / 9)])
def test_temperature_unit_c_or_f_and_a_blank_ratio_unit(tmp_path, unit, si):
    ch = _small_channels() | {"TSTC": np.full(200, 30.0 if unit == "C" else 33.0)}
    units = {"TSTC": unit, "SL": ""}
    path = _write(tmp_path / "B1run1.dat", _dat_lines(ch, units))
    _, frame, _ = _tidy(path)
    np.testing.assert_allclose(frame["T_tread_centre"], si)
    assert (frame["kappa"] == 0).all()


def _tidy_mat(tmp_path, ch):
    path = _mat(tmp_path / "B1run1.mat", ch)
    problems = Problems()
    (run,) = read_channels(path, problems=problems)
    warnings = []
    frame = channels_to_tidy(run, warnings=warnings, problems=problems)
    return path, frame, warnings, [str(p) for p in problems.finish()]


def _sr_channels():
    """Free rolling then a slip-ratio sweep at two loads, SR from the loaded radius: 1 + SR =
    (1 + kappa) RL / Re, RL / Re = 0.96 - 0.01 Fz [kN] (the tyre's free-rolling SR)."""
    ch = _small_channels(drop=("SL",))
    kappa = np.concatenate([np.zeros(100), np.linspace(-0.1, 0.1, 100)])
    fz = np.tile(np.repeat([1000.0, 2000.0], 50), 2)
    ch["FZ"], ch["FX"] = -fz, 20.0 * kappa * fz
    ch["SR"] = (1 + kappa) * (0.96 - 0.01 * fz / 1e3) - 1
    return ch, kappa


def test_older_round_without_sl_takes_sr_as_kappa_with_a_warning(tmp_path):
    """SR's free-rolling value (-5 %) is taken off: raw SR as kappa made every cornering
    sweep of a session a combined one (Fy0 fitted on 63 of 3034 points, Mz0 to 994 %)."""
    ch, kappa = _sr_channels()
    path, frame, warnings, problems = _tidy_mat(tmp_path, ch)
    assert problems == []
    np.testing.assert_allclose(frame["kappa"], kappa, atol=1e-12)
    (used,) = [w for w in warnings if w.kind == "channel"]
    assert used.channels == ("SR",) and used.action == "used as kappa" and used.count == 200
    assert str(used) == (
        f"{path}: SR: no slip ratio SL: kappa is SR, the slip ratio based on the loaded "
        "radius, scaled to its free-rolling value (-0.0550 at the median load and pressure; "
        "a + b Fz + c p + d alpha^2 fitted on 100 samples with |Fx| < 2 % of Fz) (200 of 200 "
        "samples); used as kappa")


def test_sl_without_one_finite_value_is_a_warning_then_sr_is_kappa(tmp_path):
    ch, kappa = _sr_channels()
    ch["SL"] = np.full(200, np.nan)
    _, frame, warnings, problems = _tidy_mat(tmp_path, ch)
    assert problems == []
    np.testing.assert_allclose(frame["kappa"], kappa, atol=1e-12)
    assert [(w.channels, w.action) for w in warnings if w.kind == "channel"] == [
        (("SL",), "channel not used"), (("SR",), "used as kappa")]


def test_sl_without_one_finite_value_and_no_sr_is_a_warning_not_silence(tmp_path):
    """Before: no warning at all, and the run's slip-ratio sweeps vanished."""
    ch = _small_channels() | {"SL": np.full(200, np.nan)}
    path, frame, warnings, problems = _tidy_mat(tmp_path, ch)
    assert problems == [] and frame["kappa"].isna().all()
    (empty,) = [w for w in warnings if w.kind == "channel"]
    assert str(empty) == (f"{path}: SL: no finite value in the whole run (200 of 200 "
                          "samples); channel not used")


def test_sr_pinned_at_minus_one_does_not_stand_in_for_a_missing_sl(tmp_path):
    ch = _small_channels(drop=("SL",)) | {"SR": np.full(200, -1.0)}
    path, frame, _, problems = _tidy_mat(tmp_path, ch)
    assert frame is None and problems == [f"{path}: SL: missing required channel"]


def test_older_round_without_wheel_speed_is_a_warning(tmp_path):
    ch = _small_channels(drop=("N",))
    path, frame, warnings, problems = _tidy_mat(tmp_path, ch)
    assert problems == [] and frame["omega"].isna().all() and len(frame) == 200
    (absent,) = [w for w in warnings if w.kind == "channel"]
    assert absent.channels == ("N",) and absent.action == "channel absent"
    assert "effective-radius stage is skipped" in absent.detail


def test_channel_struct_as_a_struct_array(tmp_path):
    """channel(i).name / channel(i).units: one struct per channel."""
    ch = _small_channels()
    path = tmp_path / "B1run1.mat"
    arr = np.zeros((1, len(ch)), dtype=[("name", object), ("units", object)])
    for i, k in enumerate(ch):
        arr[0, i] = (k, TTC_CHANNELS[k].si_unit)
    scipy.io.savemat(path, {k: v.reshape(-1, 1) for k, v in ch.items()} | {"channel": arr},
                     format="5")
    assert read_clean(path).units == {k: TTC_CHANNELS[k].si_unit for k in ch}


def test_a_lower_case_variable_next_to_its_upper_case_channel_is_not_taken_for_it(tmp_path):
    ch = _small_channels()
    fz = ch["FZ"].copy()
    ch["fz"] = 0.5 * fz
    run = read_clean(_mat(tmp_path / "B1run1.mat", ch, units=[
        TTC_CHANNELS[k].si_unit if k in TTC_CHANNELS else "lbf" for k in ch]))
    np.testing.assert_array_equal(run.data["FZ"], fz)
    assert run.units["FZ"] == "N" and run.units["fz"] == "lbf"


def test_a_condition_channel_without_one_finite_value_is_one_line(tmp_path):
    """Before: 'FZ: median load is nan in SI (not finite after the unit conversion)'."""
    ch = _small_channels() | {"FZ": np.full(200, np.nan)}
    path, frame, _, problems = _tidy_mat(tmp_path, ch)
    assert frame is None
    assert problems == [f"{path}: FZ: no finite value (all 200 samples are NaN/inf)"]


def test_dat_with_a_decimal_comma(tmp_path):
    ch = _small_channels()
    lines = _dat_lines()
    lines[3:] = [line.replace(".", ",") for line in lines[3:]]
    run = read_clean(_write(tmp_path / "B1run1.dat", lines))
    np.testing.assert_allclose(run.data["FY"], ch["FY"], rtol=1e-5, atol=0)  # %.6g: 5e-6


def test_import_of_dat_files_without_id_into_a_folder_named_without_letters_is_one_line(
        tmp_path):
    """The id falls back to the --out folder's name; one that makes no safe name (``---``)
    leaves none: the error names the title line the .dat has instead."""
    path = _write(tmp_path / "B1run1.dat", _dat_lines())
    assert import_refused([path], tmp_path / "---") == [(
        "error: --id: no tyre id: the files carry no 'tireid' (a TTC .dat has only its title "
        "line: 'B1 run 1') and the --out folder's name makes none; give --id")]


def test_an_id_that_makes_no_file_name_is_one_line_naming_the_option(tmp_path):
    """Before: the error said the files and the --out folder's name made no id, and to give
    --id, which the user had given."""
    path = _write(tmp_path / "B1run1.dat", _dat_lines())
    result = CliRunner().invoke(app, ["import", str(path), "--out", str(tmp_path / "out"),
                                      "--id", "///"])
    assert result.exit_code == 2 and not (tmp_path / "out").exists()
    assert result.stderr.splitlines() == [
        "error: --id: '///' makes no tyre id (a file name needs a letter, digit, '.', '_' or "
        "'-')"]


def test_two_tyres_are_not_imported_into_one_folder_without_id(tmp_path):
    """Before: a generated session with a second tireid on its drive/brake run imported with
    exit 0 into one folder named after the first tireid in alphabetical order."""
    a = _mat(tmp_path / "B1run1.mat", _small_channels())
    later = _small_channels() | {"ET": _small_channels()["ET"] + 100.0}  # not a's twin
    b = _mat(tmp_path / "B1run2.mat", later, extra={"tireid": "other tyre"})
    assert import_refused([a, b], tmp_path / "out") == [
        f"error: {a}: tireid 'small', but {b} has 'other tyre': one tyre per folder (give --id "
        "to import them as one tyre)"]


def test_sr_offset_free_rolling_at_one_load_takes_no_made_up_load_slope(tmp_path):
    """Free rolling at 1 kN only, the sweep at 2 kN, RL / Re = 0.95 at both. Before: the
    load column, constant on the free-rolling samples, shared the intercept (lstsq's
    minimum-norm answer), and the offset at 2 kN came out -0.069: kappa up to 0.022 off."""
    ch = _small_channels(drop=("SL",))
    kappa = np.concatenate([np.zeros(100), np.linspace(-0.1, 0.1, 100)])
    fz = np.repeat([1000.0, 2000.0], 100)
    ch["FZ"], ch["FX"] = -fz, 20.0 * kappa * fz
    ch["SR"] = (1 + kappa) * 0.95 - 1
    _, frame, _, problems = _tidy_mat(tmp_path, ch)
    assert problems == []
    np.testing.assert_allclose(frame["kappa"], kappa, atol=1e-12)


def test_dat_with_a_channel_named_twice_is_one_line(tmp_path):
    """Before: a second line, 'data below the header are not tab-separated numbers (Duplicate
    names are not allowed.)', about data that were never the problem ("fx" next to "FX" is
    one channel named twice since names are read in any case)."""
    lines = _dat_lines()
    lines[1] = lines[1].replace("FY", "fx")
    path = _write(tmp_path / "B1run1.dat", lines)
    assert _refused(path) == [f"{path}:2: FX: channel named twice"]


def test_sr_offset_leaves_out_the_unloaded_samples_between_sweeps(tmp_path):
    """20 samples with the tyre lifted off between sweeps (Fz 30 N, Fx 0: 'free rolling' by
    |Fx| < 2 % of Fz) where SR reads +0.3 (the radius channel reads the wheel's height). Before:
    they took part in the offset's fit and put kappa up to 0.22 off on the loaded samples."""
    ch, kappa = _sr_channels()
    lifted = np.arange(100, 120)
    ch["FZ"][lifted], ch["FX"][lifted], ch["SR"][lifted] = -30.0, 0.0, 0.3
    _, frame, _, problems = _tidy_mat(tmp_path, ch)
    assert problems == []
    loaded = np.setdiff1d(np.arange(200), lifted)
    np.testing.assert_allclose(frame["kappa"].to_numpy()[loaded], kappa[loaded], atol=1e-12)


def test_sr_offset_is_not_extrapolated_from_a_narrow_load_spread(tmp_path):
    """Free rolling at 1000 +- 10 N only, the sweep at 2000 N, RL / Re = 0.95 at both and SR
    noise 1e-4: the load slope fitted on the narrow spread is the noise's. Before: it was
    extrapolated 1 kN, kappa 2.3e-3 off (seed 4); held at the free-rolling range, 3.1e-4."""
    rng = np.random.default_rng(4)
    ch = _small_channels(drop=("SL",))
    kappa = np.concatenate([np.zeros(100), np.linspace(-0.1, 0.1, 100)])
    fz = np.concatenate([1000 + 10 * rng.standard_normal(100), np.full(100, 2000.0)])
    ch["FZ"], ch["FX"] = -fz, 20.0 * kappa * fz
    ch["SR"] = (1 + kappa) * 0.95 - 1 + 1e-4 * rng.standard_normal(200)
    _, frame, _, problems = _tidy_mat(tmp_path, ch)
    assert problems == []
    np.testing.assert_allclose(frame["kappa"], kappa, atol=5e-4)
