"""Eigenfrequencies (and any hand-entered characteristic) are inputs: passed through.

Free-hanging eigenfrequencies come from a modal test or FEM, not from the Flatplank; they sit in
the folder's characteristic table(s) and go into the extracted table unchanged. Other
characteristics given by hand are passed through too, unless the raw runs already gave the same
quantity at the same pressure and load (measured runs win; the diagnostics say which rows were
dropped).
"""
from __future__ import annotations

import math

import pandas as pd

from identify.extract.diagnostics import row

__all__ = ["pass_through"]


def _text(value) -> str:
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)


def _key(quantity, pi_bar, fz, gamma, mode) -> tuple:
    g = None if gamma is None or (isinstance(gamma, float) and math.isnan(gamma)) else \
        round(float(gamma), 6)
    return (quantity, round(float(pi_bar), 6), round(float(fz), 3), g, _text(mode))


def pass_through(table: pd.DataFrame, extracted: list[dict]) -> tuple[list[dict], list[str]]:
    """Rows of a tidy characteristic table that go into the extraction output.

    Parameters
    ----------
    table : pandas.DataFrame
        The folder's characteristic table (``identify.io``; SI values, ``pi_bar`` in bar).
    extracted : list of dict
        Rows extracted from raw runs.

    Returns
    -------
    (list of dict, list of str)
        The rows to add (characteristic-table records) and a note per row dropped because the
        raw runs gave it.
    """
    if table is None or table.empty:
        return [], []
    have = {_key(r["quantity"], r["pi_bar"], r["Fz_N"], r["gamma_deg"], r["mode"])
            for r in extracted}
    out, notes = [], []
    for rec in table.to_dict("records"):
        mode = _text(rec.get("mode"))
        key = _key(rec["quantity"], rec["pi_bar"], rec["Fz_N"], rec.get("gamma_deg"), mode)
        if key in have:
            notes.append(f"{rec['quantity']} at {rec['pi_bar']:g} bar, {rec['Fz_N']:g} N from "
                         f"'{rec.get('run', '')}' dropped: extracted from the raw runs")
            continue
        out.append(row(rec["quantity"], rec["pi_bar"], rec["Fz_N"], rec["value"],
                       gamma_deg=rec.get("gamma_deg", math.nan),
                       Vx_mps=rec.get("Vx_mps", math.nan), mode=mode))
    return out, notes
