"""The bundled default tyre: a plausible MF 6.1 file for a 225/50 R17 passenger tyre.

Shape and friction coefficients are typical passenger-car values (ISO-W signs: PKY1 < 0, so
alpha > 0 gives Fy < 0 and Mz > 0). The keys the Flatplank characteristics determine are derived
from :data:`identify.simulate.coefficients.DEFAULT_RELATIONS` and the thesis calibration
(``calibrate.py``): VERTICAL_STIFFNESS, Q_FZ2, PFZ1 from the qFz relation; PKY1, PKY2, PPY1,
PPY2 from the joint CFy/sigma_y fit; Q_RE0, BREFF, DREFF, FREFF from the Re fit; the structural
stiffnesses and the ring keys from the relations. Pressure keys take literature-like values
(PPY5, PPMX1, PPZ2: the thesis' hand-tuned -0.15, -0.10, -0.60; QSY7 0.87, QSY8 -0.4).

``python -m identify.simulate.default_tyre`` rewrites ``data/tyre_225_50R17.tir``.
"""
from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from identify.io.tir import write_tir
from identify.model.relations import YawT1, mf_from_qfz
from identify.simulate.coefficients import DEFAULT_RELATIONS, Relations

__all__ = ["default_tir_path", "default_tyre_values", "write_default_tir"]

_BASE: dict[str, float | str] = {
    "TYRESIDE": "LEFT", "LONGVL": 16.7, "VXLOW": 1.0,
    "UNLOADED_RADIUS": 0.3205, "WIDTH": 0.225, "ASPECT_RATIO": 0.5, "RIM_RADIUS": 0.2159,
    "RIM_WIDTH": 0.1905, "INFLPRES": 250000.0, "NOMPRES": 250000.0,
    "MASS1": 10.2, "IXX": 0.45, "IYY": 0.82,
    "FNOMIN": 5000.0, "VERTICAL_DAMPING": 300.0, "Q_V1": 0.0007, "Q_V2": 0.02,
    "Q_FCX": 0.0, "Q_FCY": 0.0,
    # Re (calibrate.py, worst thesis cell 0.28 %)
    "Q_RE0": 1.01895, "BREFF": 4.0, "DREFF": 0.13987, "FREFF": 0.0651565,
    "Q_RA1": 0.55, "Q_RA2": 1.15, "Q_RB1": 0.95, "Q_RB2": -0.9,
    "PRESMIN": 150000.0, "PRESMAX": 350000.0, "FZMIN": 100.0, "FZMAX": 10000.0,
    "KPUMIN": -1.5, "KPUMAX": 1.5, "ALPMIN": -0.5, "ALPMAX": 0.5,
    "CAMMIN": -0.28, "CAMMAX": 0.28,
    # longitudinal
    "PCX1": 1.60, "PDX1": 1.12, "PDX2": -0.08, "PDX3": 2.0, "PEX1": 0.30, "PEX2": 0.12,
    "PEX3": -0.05, "PEX4": 0.15, "PKX1": 23.0, "PKX2": -1.5, "PKX3": 0.25, "PHX1": 0.0004,
    "PHX2": 0.0002, "PVX1": 0.0, "PVX2": 0.0,
    "PPX1": -0.45, "PPX2": 0.20, "PPX3": -0.08, "PPX4": 0.06,
    "RBX1": 12.0, "RBX2": 9.0, "RBX3": 0.0, "RCX1": 1.05, "REX1": -0.40, "REX2": 0.0,
    "RHX1": 0.0,
    # overturning
    "QSX1": -0.005, "QSX2": 0.55, "QSX3": 0.04, "QSX4": 0.0, "QSX5": 0.0, "QSX6": 0.0,
    "QSX7": 0.0, "QSX8": 0.0, "QSX9": 0.0, "QSX10": 0.0, "QSX11": 0.0, "PPMX1": -0.10,
    # lateral (PKY1, PKY2, PPY1, PPY2: calibrate.py joint CFy/sigma_y fit)
    "PCY1": 1.35, "PDY1": 1.05, "PDY2": -0.09, "PDY3": 2.5, "PEY1": -0.45, "PEY2": -0.25,
    "PEY3": 0.10, "PEY4": 0.0, "PEY5": 0.0,
    "PKY1": -29.8592, "PKY2": 3.0, "PKY3": 0.4, "PKY4": 2.0, "PKY5": 0.0, "PKY6": -0.85,
    "PKY7": -0.15, "PHY1": 0.0015, "PHY2": 0.0005, "PVY1": 0.012, "PVY2": 0.004,
    "PVY3": -0.30, "PVY4": 0.0,
    "PPY1": 0.455346, "PPY2": 0.779793, "PPY3": -0.10, "PPY4": 0.08, "PPY5": -0.15,
    "RBY1": 11.0, "RBY2": 8.5, "RBY3": 0.0, "RBY4": 0.0, "RCY1": 1.05, "REY1": -0.10,
    "REY2": 0.0, "RHY1": 0.0, "RHY2": 0.0, "RVY1": 0.0, "RVY2": 0.0, "RVY3": 0.0,
    "RVY4": 10.0, "RVY5": 1.9, "RVY6": 10.0,
    # rolling resistance
    "QSY1": 0.0085, "QSY2": 0.0, "QSY3": 0.0006, "QSY4": 3e-05, "QSY5": 0.0, "QSY6": 0.0,
    "QSY7": 0.87, "QSY8": -0.40,
    # aligning
    "QBZ1": 9.5, "QBZ2": -1.2, "QBZ3": 0.0, "QBZ4": 0.2, "QBZ5": 0.1, "QBZ9": 0.0,
    "QBZ10": 0.5, "QCZ1": 1.15, "QDZ1": 0.11, "QDZ2": -0.005, "QDZ3": 0.4, "QDZ4": 0.0,
    "QDZ6": 0.002, "QDZ7": -0.001, "QDZ8": -0.08, "QDZ9": 0.01, "QDZ10": 0.0, "QDZ11": 0.0,
    "QEZ1": -1.6, "QEZ2": 0.3, "QEZ3": 0.0, "QEZ4": 0.2, "QEZ5": 0.0, "QHZ1": 0.0015,
    "QHZ2": -0.001, "QHZ3": 0.08, "QHZ4": 0.0, "PPZ1": -0.45, "PPZ2": -0.60,
    "SSZ1": 0.01, "SSZ2": -0.005, "SSZ3": 0.2, "SSZ4": 0.0,
}


def default_tyre_values(relations: Relations = DEFAULT_RELATIONS) -> dict[str, float | str]:
    """Every non-default key of the default tyre (parameter-table names, SI)."""
    values = dict(_BASE)
    r0, fz0 = values["UNLOADED_RADIUS"], values["FNOMIN"]
    v = relations.vertical
    values.update(mf_from_qfz(v.qfz1, v.qfz2, v.qfz3, r0, fz0))
    cfx = relations.cfx.rebased(fz0)
    cfy = relations.cfy.rebased(fz0)
    values.update({"LONGITUDINAL_STIFFNESS": cfx.nominal, "PCFX1": cfx.p1, "PCFX2": cfx.p2,
                   "PCFX3": cfx.p3, "LATERAL_STIFFNESS": cfy.nominal, "PCFY1": cfy.p1,
                   "PCFY2": cfy.p2, "PCFY3": cfy.p3})
    cmz = relations.cmz
    scale = fz0 / cmz.fz0  # the same CMz(Fz) written with the .tir's FNOMIN
    if isinstance(cmz, YawT1):
        values.update({"YAW_STIFFNESS": cmz.nominal * scale, "PCMZ1": cmz.p1, "CMZ_FORM": 1})
    else:
        values.update({"YAW_STIFFNESS": cmz.nominal, "PCMZ1": cmz.p1 * scale,
                       "PCMZ2": cmz.p2 * scale ** 2, "PCMZ3": cmz.p3, "CMZ_FORM": 2})
    ring = relations.ring
    values.update({"BELT_MASS": ring.m_b, "BELT_IXX": ring.i_bx, "BELT_IYY": ring.i_by,
                   "FREQ_LONG": float(ring.frequency("x", 0.0)),
                   "FREQ_LAT": float(ring.frequency("y", 0.0)),
                   "FREQ_YAW": float(ring.frequency("psi", 0.0)),
                   "FREQ_WINDUP": float(ring.frequency("theta", 0.0))})
    for key, f in zip(("F_X", "F_Y", "F_Z", "F_THETA", "F_GAMMA", "F_PSI"), ring.f):
        values[key] = f
    return values


def default_tir_path() -> Path:
    """Path of the bundled ``tyre_225_50R17.tir``."""
    return Path(str(files("identify.simulate").joinpath("data", "tyre_225_50R17.tir")))


def write_default_tir(path: str | Path | None = None) -> Path:
    """Write the default tyre as MF 6.1 (to the bundled location unless ``path`` is given)."""
    target = Path(path) if path is not None else default_tir_path()
    return write_tir(target, default_tyre_values(), fittyp=61, comment_lines=(
        "mfid default tyre 225/50 R17 for the rig simulator (identify.simulate.default_tyre)",
        "Flatplank-determined keys calibrated to op het Veld (2007) thesis characteristics",
    ))


if __name__ == "__main__":  # pragma: no cover
    print(write_default_tir())
