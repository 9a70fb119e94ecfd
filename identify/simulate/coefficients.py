"""Default pressure-relation coefficients of the simulator, in the style of the thesis tyre.

The numbers of CFz, CFx, CFy (with PKY1/PKY2/PPY1/PPY2 of the default .tir) and the Re keys come
from ``python -m identify.simulate.calibrate``: a relative least-squares fit to the real
Flatplank characteristics of the 225/50 R17 tyre of op het Veld (2007, chapter 4;
``measurements/thesis-225-50R17/characteristics.csv``). CMz and the rigid ring have no thesis table:
CMz uses the T1 form with pCMz1 = -0.55 (the thesis saw CMz fall ~12 % per +0.5 bar); the
ring stiffnesses give MF-Swift-typical eigenfrequencies (80/42/80 Hz, 70 Hz wind-up, 50 Hz
camber/yaw) with the pressure scalings f_x .. f_psi the thesis fitted (0.65, 0.74, 0.65, 0.69,
0.49, 0.49).

:func:`relations_from_tir` gives the relations a .tir itself carries (the MF-Swift structural
keys), so that a folder simulated from any .tir has that tyre's stiffnesses; for the bundled
tyre they equal :data:`DEFAULT_RELATIONS` (the .tir was written from them).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

from identify.model.relations import (
    LoadPressureStiffness,
    SidewallRing,
    VerticalQFz,
    YawT1,
    YawT2,
    qfz_from_mf,
)

__all__ = ["Relations", "DEFAULT_RELATIONS", "RELATION_NAMES", "relations_from_tir"]


@dataclass(frozen=True)
class Relations:
    """The structural relations a simulated tyre obeys on the Flatplank.

    Attributes
    ----------
    p0 : float
        Reference pressure of every dpi [Pa] (the .tir NOMPRES).
    vertical : VerticalQFz
        Fz(rho, dpi) [N].
    cfx, cfy : LoadPressureStiffness
        Locked-hub longitudinal and lateral stiffness [N/m].
    cmz : YawT1 or YawT2
        Parking (yaw) stiffness [N m/rad].
    ring : SidewallRing
        Rigid-ring sidewall stiffnesses and inertias (free-hanging eigenfrequencies).
    """

    p0: float
    vertical: VerticalQFz
    cfx: LoadPressureStiffness
    cfy: LoadPressureStiffness
    cmz: YawT1 | YawT2
    ring: SidewallRing

    def to_dict(self) -> dict:
        """JSON-safe dict, one entry per relation."""
        return {"p0": self.p0, "CFz": {"form": "qFz", **self.vertical.to_dict()},
                "CFx": {"form": "load_pressure", **self.cfx.to_dict()},
                "CFy": {"form": "load_pressure", **self.cfy.to_dict()},
                "CMz": self.cmz.to_dict(), "ring": self.ring.to_dict()}

    def with_value(self, dotted: str, value: float) -> Relations:
        """A copy with one coefficient changed, named ``"CFy.p2"``, ``"CMz.p1"``, ``"CFz.qfz3"``.

        Raises
        ------
        KeyError
            For an unknown relation or coefficient.
        """
        relation, _, name = dotted.partition(".")
        attr = RELATION_NAMES.get(relation)
        if attr is None or attr == "ring":
            raise KeyError(dotted)
        current = getattr(self, attr)
        if name not in {f.name for f in fields(current)}:
            raise KeyError(dotted)
        return replace(self, **{attr: replace(current, **{name: float(value)})})


#: Relation names (as in the characteristic table) -> attribute.
RELATION_NAMES = {"CFz": "vertical", "CFx": "cfx", "CFy": "cfy", "CMz": "cmz", "ring": "ring"}

DEFAULT_RELATIONS = Relations(
    p0=250000.0,
    # calibrate.py fit to the thesis CFz (worst cell 1.5 %)
    vertical=VerticalQFz(qfz1=217608.0, qfz2=827108.0, qfz3=0.787517),
    # quadratic-load form, Fz0 = 4 kN as in the thesis test (worst cell 1.2 %)
    cfx=LoadPressureStiffness(nominal=225408.0, p1=0.230132, p2=-0.280917, p3=0.206717,
                              fz0=4000.0),
    # fitted together with Kya to CFy and sigma_y (worst cells 6.6 % and 7.0 %)
    cfy=LoadPressureStiffness(nominal=139348.0, p1=0.104703, p2=0.0, p3=0.458703, fz0=5000.0),
    cmz=YawT1(nominal=5200.0, p1=-0.55, fz0=5000.0),
    ring=SidewallRing(c0=(1.97e6, 5.43e5, 1.97e6, 1.354e5, 3.75e4, 3.75e4),
                      f=(0.65, 0.74, 0.65, 0.69, 0.49, 0.49), m_b=7.8, i_bx=0.38, i_by=0.70),
)


def relations_from_tir(params: Mapping[str, float],
                       ring: SidewallRing = DEFAULT_RELATIONS.ring) -> Relations:
    """The Flatplank relations a .tir describes (docs/relations.md, in MF-Swift keys).

    p0 = NOMPRES; CFz from VERTICAL_STIFFNESS, Q_FZ2, PFZ1 (the MF vertical force at standstill,
    ``qfz_from_mf``); CFx and CFy from LONGITUDINAL_/LATERAL_STIFFNESS with PCFX1..3 / PCFY1..3
    at Fz0 = FNOMIN; CMz from YAW_STIFFNESS, PCMZ1 (form T1) or, with CMZ_FORM = 2, PCMZ1..3
    (form T2). The .tir has no sidewall stiffnesses of the rigid ring: ``ring`` supplies them.

    Parameters
    ----------
    params : mapping
        Numeric .tir values in SI, complete (``read_tir(path).params()`` fills MFeval's
        defaults for missing keys).
    ring : SidewallRing
        Rigid-ring sidewall stiffnesses and inertias.

    Returns
    -------
    Relations
    """
    P = {k: float(params[k]) for k in (
        "NOMPRES", "FNOMIN", "UNLOADED_RADIUS", "VERTICAL_STIFFNESS", "Q_FZ2", "PFZ1",
        "LONGITUDINAL_STIFFNESS", "PCFX1", "PCFX2", "PCFX3", "LATERAL_STIFFNESS", "PCFY1",
        "PCFY2", "PCFY3", "YAW_STIFFNESS", "PCMZ1")}
    fz0 = P["FNOMIN"]
    qfz1, qfz2, qfz3 = qfz_from_mf(P["VERTICAL_STIFFNESS"], P["Q_FZ2"], P["PFZ1"],
                                   P["UNLOADED_RADIUS"], fz0)
    if round(float(params.get("CMZ_FORM", 1.0))) == 2:
        cmz: YawT1 | YawT2 = YawT2(P["YAW_STIFFNESS"], P["PCMZ1"],
                                   float(params.get("PCMZ2", 0.0)),
                                   float(params.get("PCMZ3", 0.0)), fz0)
    else:
        cmz = YawT1(P["YAW_STIFFNESS"], P["PCMZ1"], fz0)
    return Relations(
        p0=P["NOMPRES"], vertical=VerticalQFz(qfz1, qfz2, qfz3),
        cfx=LoadPressureStiffness(P["LONGITUDINAL_STIFFNESS"], P["PCFX1"], P["PCFX2"],
                                  P["PCFX3"], fz0),
        cfy=LoadPressureStiffness(P["LATERAL_STIFFNESS"], P["PCFY1"], P["PCFY2"], P["PCFY3"],
                                  fz0),
        cmz=cmz, ring=ring)
