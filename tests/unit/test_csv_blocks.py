"""The numeric CSV fast path in blocks (issue 15, large files): the same table and the same lines
in messages whatever the block size, plain or gzip, with or without spaces after the commas;
the quirk cleaning never writes into the arrays it was given."""
from __future__ import annotations

import gzip

import numpy as np
import pytest

from identify.io import common
from identify.io.common import Problems, read_numeric_csv
from identify.io.trailer.files import channels_to_tidy, read_channels
from tests.measurement_cases import trailer_channels

N = 61


def _text(sep: str = ",", nan_row: int | None = None, blank_after: int | None = None) -> str:
    ch = trailer_channels(n=N)
    names = list(ch)
    lines = [sep.join(names)]
    for i in range(N):
        cells = [repr(float(ch[n][i])) for n in names]
        if i == nan_row:
            cells[names.index("FYW")] = "nan" if sep == "," else " nan"
        lines.append(sep.join(cells))
        if i == blank_after:
            lines.append("")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("compress", [False, True])
@pytest.mark.parametrize("sep", [",", ", "])
def test_blocks_give_the_whole_table(tmp_path, monkeypatch, compress, sep):
    text = _text(sep, nan_row=30, blank_after=10)
    path = tmp_path / "run.csv"
    path.write_bytes(gzip.compress(text.encode()) if compress else text.encode())
    whole, _, _ = read_numeric_csv(path, Problems(strict=True), allow_nan=True)
    monkeypatch.setattr(common, "BLOCK_ROWS", 7)  # blocks end inside the blank line, the NaN
    blocks, _, _ = read_numeric_csv(path, Problems(strict=True), allow_nan=True)
    assert len(blocks) == N and list(blocks.columns) == list(whole.columns)
    for c in whole.columns:
        np.testing.assert_array_equal(blocks[c].to_numpy(), whole[c].to_numpy(), err_msg=c)
    assert np.isnan(blocks["FYW"].to_numpy()[30])
    ref = trailer_channels(n=N)
    np.testing.assert_array_equal(blocks["FX"].to_numpy(), ref["FX"])


def test_lines_in_messages_across_blocks(tmp_path, monkeypatch):
    monkeypatch.setattr(common, "BLOCK_ROWS", 5)
    path = tmp_path / "run.csv"
    path.write_text(_text(nan_row=30))  # data row 30 (from 0) is line 32
    warnings: list = []
    (ch,) = read_channels(path)
    channels_to_tidy(ch, warnings=warnings)
    assert {w.kind: w.line for w in warnings} == {"nan": 32, "rows": 32}
    lines = path.read_text().splitlines()
    lines[50] = lines[50].replace(",", ",x", 1)  # line 51: a cell that is not a number
    path.write_text("\n".join(lines) + "\n")
    problems = Problems()
    assert read_numeric_csv(path, problems, allow_nan=True) is None
    (problem,) = problems.finish()
    assert problem.line == 51 and problem.key == "LONGVEL" and "not a number: 'x" in \
        problem.message


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_warning_lines_count_blank_lines(tmp_path, newline):
    """pandas skips blank lines: a warning after them still names the sample's own line."""
    path = tmp_path / "run.csv"
    plain = _text(nan_row=30).replace("\n", newline).encode()
    path.write_bytes(plain)
    (ch,) = read_channels(path)
    assert ch.first_line == 2  # lines and rows one to one: no line table
    path.write_bytes(plain + newline.encode() * 3)
    (ch,) = read_channels(path)
    assert ch.first_line == 2  # blank lines at the end move no row
    text = _text(nan_row=30, blank_after=10).replace("\n", newline)
    path.write_bytes(text.replace(newline, newline * 2, 1).encode())  # and one after the header
    warnings: list = []
    (ch,) = read_channels(path)
    channels_to_tidy(ch, warnings=warnings)
    line = 1 + text.splitlines().index(plain.decode().splitlines()[31]) + 1  # data row 30
    assert line == 34
    assert {w.kind: w.line for w in warnings} == {"nan": line, "rows": line}


def test_cleaning_does_not_write_the_channels(tmp_path):
    ch = trailer_channels(n=200)
    ch["FYW"] = ch["FYW"].copy()
    ch["FYW"][100] += 5e4  # a spike
    ch["FZW"] = ch["FZW"].copy()
    ch["FZW"][50:53] = 0.0  # a dropout
    path = tmp_path / "run.csv"
    names = list(ch)
    rows = [",".join(repr(float(ch[n][i])) for n in names) for i in range(200)]
    path.write_text("\n".join([",".join(names), *rows]) + "\n")
    (run,) = read_channels(path)
    before = {k: v.copy() for k, v in run.data.items()}
    warnings: list = []
    frame = channels_to_tidy(run, warnings=warnings)
    assert {"spike", "dropout", "rows"} <= {w.kind for w in warnings}
    assert len(frame) == 200 - 4
    for k, v in run.data.items():
        np.testing.assert_array_equal(v, before[k], err_msg=k)


@pytest.mark.parametrize("allow_nan", [True, False])
def test_suspect_rows_report_what_the_full_walk_reports(tmp_path, monkeypatch, allow_nan):
    lines = _text(nan_row=3, blank_after=20).splitlines()

    def cell(i: int, text: str) -> None:
        cells = lines[i].split(",")
        cells[1] = text
        lines[i] = ",".join(cells)

    cell(8, "NA")  # pandas: NaN; float(): not a number
    lines[12] = ",".join(lines[12].split(",")[:-2])  # a short row
    cell(30, "")  # an empty cell
    cell(40, "9" * 140_000)  # over the csv module's field limit (pandas: inf)
    path = tmp_path / "run.csv"
    path.write_text("\n".join(lines) + "\n")

    def listed():
        problems = Problems()
        read_numeric_csv(path, problems, allow_nan=allow_nan)
        return [str(p) for p in problems.finish()]

    fast = listed()
    monkeypatch.setattr(common, "walk_suspects", lambda *args: False)
    assert fast == listed()
    assert any(":9: " in p and "not a number: 'NA'" in p for p in fast)
    assert any(":13: " in p and "ragged row" in p for p in fast)
    assert fast[-1].endswith(":41: cannot parse CSV: field larger than field limit (131072)")


@pytest.mark.parametrize("fast", [True, False])
@pytest.mark.parametrize("spaces", ["   ", "\t", " \r"])
def test_a_line_of_spaces_is_a_blank_line(tmp_path, monkeypatch, fast, spaces):
    """pandas skips a line of only spaces or tabs as it skips a blank one: the row walks do
    the same, so a NaN cell below it is a warning on its own line, not a ragged row."""
    if not fast:
        monkeypatch.setattr(common, "walk_suspects", lambda *args: False)
    path = tmp_path / "run.csv"
    path.write_bytes(_text(nan_row=30, blank_after=10).replace("\n\n", f"\n{spaces}\n")
                     .encode())
    warnings: list = []
    (ch,) = read_channels(path)
    channels_to_tidy(ch, warnings=warnings)
    assert {w.kind: w.line for w in warnings} == {"nan": 33, "rows": 33}  # data row 30
