"""Simulated Tire Test Consortium sessions for the TTC reader, segmentation and import tests."""
from __future__ import annotations

from pathlib import Path

from identify.io.tir import read_tir
from identify.simulate.default_tyre import default_tir_path
from identify.simulate.ttc import TtcSession, simulate_ttc


def session(path: Path, **settings) -> TtcSession:
    """A session of the bundled 225/50 R17 tyre written to ``path``."""
    return simulate_ttc(read_tir(default_tir_path()).params(), path, **settings)
