"""The simulator's Flatplank relations come from the .tir it is given (issue 18): a folder
simulated from another tyre carries that tyre's vertical and structural stiffnesses, not the
bundled tyre's."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from identify.io.tir import read_tir
from identify.model.relations import YawT2, dpi
from identify.simulate import DEFAULT_RELATIONS, default_tir_path
from identify.simulate.coefficients import relations_from_tir
from identify.simulate.default_tyre import default_tyre_values
from tests.reference_data import MFEVAL_DIR

FZ = np.array([1000.0, 2000.0, 3000.0, 5000.0, 7000.0, 9000.0])
P_BAR = np.array([1.9, 2.2, 2.5, 2.7, 3.0])[:, None]


def test_bundled_tyre_gives_the_default_relations():
    """The bundled .tir was written from DEFAULT_RELATIONS (CFx rebased from Fz0 = 4 kN to
    FNOMIN): every characteristic agrees to round-off."""
    rel = relations_from_tir(read_tir(default_tir_path()).params())
    dp = dpi(P_BAR * 1e5, rel.p0)
    assert rel.p0 == DEFAULT_RELATIONS.p0
    for name in ("cfx", "cfy", "cmz"):
        np.testing.assert_allclose(getattr(rel, name)(FZ, dp),
                                   getattr(DEFAULT_RELATIONS, name)(FZ, dp), rtol=1e-12)
    np.testing.assert_allclose(rel.vertical.cfz_at_load(FZ, dp),
                               DEFAULT_RELATIONS.vertical.cfz_at_load(FZ, dp), rtol=1e-12)
    assert rel.ring == DEFAULT_RELATIONS.ring


def test_form_t2_yaw_stiffness_round_trips():
    """CMZ_FORM = 2 (PCMZ1..3, mfid's extension keys) is read back as the T2 relation."""
    t2 = YawT2(nominal=5200.0, p1=0.8, p2=0.2, p3=-0.5, fz0=4000.0)
    rel = relations_from_tir(default_tyre_values(dataclasses.replace(DEFAULT_RELATIONS, cmz=t2)))
    dp = dpi(P_BAR * 1e5, rel.p0)
    np.testing.assert_allclose(rel.cmz(FZ, dp), t2(FZ, dp), rtol=1e-12)


def test_example_tyre_relations_are_its_own_keys():
    """MF 6.1 example file: NOMPRES 2.6 bar, FNOMIN 6752 N; CFz at FNOMIN and NOMPRES is its
    VERTICAL_STIFFNESS, CFx/CFy/CMz there are LONGITUDINAL_/LATERAL_/YAW_STIFFNESS."""
    P = read_tir(MFEVAL_DIR / "MagicFormula61_Paramerters.tir").params()
    rel = relations_from_tir(P)
    assert rel.p0 == 260000.0
    fz0 = P["FNOMIN"]
    assert rel.vertical.cfz_at_load(fz0, 0.0) == pytest.approx(P["VERTICAL_STIFFNESS"],
                                                                rel=1e-12)
    assert rel.cfx(fz0, 0.0) == pytest.approx(P["LONGITUDINAL_STIFFNESS"], rel=1e-12)
    assert rel.cfy(fz0, 0.0) == pytest.approx(P["LATERAL_STIFFNESS"], rel=1e-12)
    assert rel.cmz(fz0, 0.0) == pytest.approx(P["YAW_STIFFNESS"], rel=1e-12)
    # the pressure and load terms: CFy at 7 kN, 3 bar from PCFY1..3
    dfz, dp = (7000.0 - fz0) / fz0, (3e5 - 2.6e5) / 2.6e5
    assert rel.cfy(7000.0, dp) == pytest.approx(P["LATERAL_STIFFNESS"] * (
        1 + P["PCFY1"] * dfz + P["PCFY2"] * dfz ** 2) * (1 + P["PCFY3"] * dp), rel=1e-12)
    assert rel.vertical.qfz3 == P["PFZ1"]
