"""Where the tests' outside reference data live: tests/data/reference (see its PROVENANCE.md).

MFeval 4.3 golden tables, MFeval 4.0 sweep grids with their three public .tir files, and the
thesis's measured Flatplank characteristics, copied into the repository so that every clone runs
the whole suite.
"""
from __future__ import annotations

import csv
from pathlib import Path

REFERENCE_DIR = Path(__file__).resolve().parent / "data" / "reference"
#: MFeval 4.3 outputs for the TEST-A parameter set (testA_61.tir, testA_62.tir).
GOLDEN_DIR = REFERENCE_DIR / "golden"
#: MFeval 4.0 sweep grids and the three .tir files they were computed from.
MFEVAL_DIR = REFERENCE_DIR / "mfeval"
#: Measured Flatplank characteristics of the thesis tyre (225/50 R17).
THESIS_CSV = REFERENCE_DIR / "thesis_characteristics.csv"
#: The three .tir files of the MFeval grids (stems).
MFEVAL_FILES = ("MagicFormula61_Paramerters", "MagicFormula62_Paramerters", "reference_tire_tvd3")


def mfeval_params(stem: str) -> dict[str, float | str]:
    """MFeval's own parse of ``<stem>.tir`` (``<stem>__params_parsed.csv``): name -> number, or
    the string without its quotes."""
    with open(MFEVAL_DIR / f"{stem}__params_parsed.csv", newline="") as fh:
        rows = list(csv.reader(fh))[1:]
    out: dict[str, float | str] = {}
    for name, text in rows:
        try:
            out[name] = float(text)
        except ValueError:
            out[name] = text.strip("'")
    return out
