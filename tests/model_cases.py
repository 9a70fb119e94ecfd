"""Shared inputs for model tests: the bundled TEST-A parameter sets and random operating points."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from identify.io.tir import read_tir

TIR_DIR = Path(__file__).parent / "data" / "tir"


def params(fittyp: int) -> dict[str, float]:
    """TEST-A (tests/data/reference/PROVENANCE.md) written by our .tir writer, FITTYP 61 or 62."""
    return read_tir(TIR_DIR / f"testA_{fittyp}.tir").params()


def random_points(n: int, seed: int, edge_cases: bool = True) -> dict[str, np.ndarray]:
    """Random combined-slip operating points over the box the equations were checked on against
    MFeval 4.3.

    Fz 0-13 kN, kappa -1.2..0.6, alpha +-0.5 rad, gamma +-0.12 rad, Vx -5..35 m/s,
    p 150-420 kPa; with ``edge_cases`` the first rows hold zero load, zero and low speed and a
    locked wheel.
    """
    rng = np.random.default_rng(seed)
    pts = {
        "fz": rng.uniform(0, 13000, n), "kappa": rng.uniform(-1.2, 0.6, n),
        "alpha": rng.uniform(-0.5, 0.5, n), "gamma": rng.uniform(-0.12, 0.12, n),
        "vx": rng.uniform(-5, 35, n), "p": rng.uniform(1.5e5, 4.2e5, n),
    }
    if edge_cases:
        pts["fz"][:5] = 0.0
        pts["vx"][5:10] = 0.0
        pts["vx"][10:15] = 0.4
        pts["kappa"][15:20] = -1.0
        pts["fz"][20:25] = 50.0
    return pts
