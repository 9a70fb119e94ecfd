"""The discovery transcripts of docs/commands.md are what ``bench/discovery_examples.py``
prints for that page's commands, and the worked example's .tir agrees with its discovery.json
and reproduces the printed errors. Simulates two folders: a few minutes."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from identify.report import discovery as discovery_pdf
from tests.bench_modules import load_bench
from tests.discover_cases import assert_consistent

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "commands.md"
MARK = re.compile(r"^<!-- discovery transcript: (\w+) -->$")


def page_transcripts() -> dict[str, str]:
    """name -> the indented block after each ``<!-- discovery transcript: name -->``."""
    lines = PAGE.read_text(encoding="utf-8").splitlines()
    out = {}
    for i, line in enumerate(lines):
        m = MARK.match(line)
        if not m:
            continue
        j = i + 1
        while j < len(lines) and not lines[j].strip():
            j += 1
        block = []
        while j < len(lines) and (lines[j].startswith("    ") or not lines[j].strip()):
            block.append(lines[j][4:])
            j += 1
        out[m.group(1)] = "\n".join(block).strip("\n")
    return out


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    """The bench's transcripts, each discovery.pdf drawn with one residual-map page (the
    first problem's: an accepted effect's when there is one) instead of up to MAX_PROBLEMS:
    the transcripts, discovery.json and the .tir do not depend on the PDF's pages, and the
    pages were a third of the run (the PDF's drawing: tests/integration/test_discover_cli.py)."""
    work = tmp_path_factory.mktemp("discovery-examples")
    mod = load_bench("discovery_examples")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(discovery_pdf, "MAX_PROBLEMS", 1)
        return work, mod.run(work), mod.EXAMPLES


def test_page_transcripts_are_current(examples):
    _, produced, names = examples
    shown = page_transcripts()
    assert sorted(shown) == sorted(names)
    for name in names:
        assert shown[name] == produced[name].strip("\n"), (
            f"docs/commands.md: transcript {name!r} is stale")


def test_worked_example_tir_equals_discovery(examples):
    """Every accepted coefficient of discovery.json is the .tir's; every problem whose
    parameters are .tir keys, evaluated with the .tir alone, has the final error."""
    work, _, _ = examples
    out = work / "fits" / "hidden" / "discovery"
    assert assert_consistent(out, work / "hidden", "hidden") >= 9
    doc = json.loads((out / "discovery.json").read_text())
    ppy5 = [a["coefficients"]["PPY5"] for a in doc["accepted"] if a["name"] == "PPY5"]
    assert len(ppy5) == 1 and ppy5[0] == pytest.approx(-0.15, abs=0.03)
    assert doc["model"]["sources"]["PPY5"] == "MF/Fy"
