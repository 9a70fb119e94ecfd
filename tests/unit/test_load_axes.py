"""Axis conversions to ISO-W: SAE signs and TYDEX-C (wheel centre) -> W (contact point)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from identify.io.axes import c_to_w, sae_to_iso_w, to_iso_w
from identify.io.flatplank import hub_to_contact
from tests.reference_data import GOLDEN_DIR


def _row(**values) -> pd.DataFrame:
    base = dict(alpha=0.0, kappa=0.0, gamma=0.0, Fx=0.0, Fy=0.0, Fz=0.0, Mx=0.0, My=0.0, Mz=0.0)
    base.update(values)
    return pd.DataFrame({k: [v] for k, v in base.items()})


def test_sae_known_sign_case():
    # A tyre at positive ISO slip angle pushed to the right, seen by an SAE rig (y right,
    # z down): SAE alpha < 0, Fy > 0 (to the right), Fz < 0 (road pushes up), Mz < 0.
    sae = _row(alpha=-0.05, kappa=0.02, gamma=0.01, Fx=300.0, Fy=3194.0, Fz=-5000.0, Mx=-68.0,
               My=18.0, Mz=-80.0)
    iso = sae_to_iso_w(sae).iloc[0]
    assert iso.alpha == 0.05 and iso.Fy == -3194.0 and iso.Mz == 80.0
    assert iso.Fy < 0 and iso.Mz > 0 and iso.Fz == 5000.0 > 0  # golden-table signs, Fz up
    assert (iso.Fx, iso.Mx, iso.kappa, iso.gamma) == (300.0, -68.0, 0.02, 0.01)
    assert iso.My == -18.0  # rolling forward: My < 0 in ISO-W
    assert sae.Fy.iloc[0] == 3194.0  # input untouched


def test_sae_mapping_reproduces_golden_signs():
    gold = np.loadtxt(GOLDEN_DIR / "gold_61_111.csv", delimiter=",")[0]  # P1: alpha = +0.05
    fx, fy, fz, mx, my, mz, kappa, alpha, gamma = gold[:9]
    assert alpha == 0.05 and fy < 0 and mz > 0
    sae = _row(alpha=-alpha, kappa=kappa, gamma=gamma, Fx=fx, Fy=-fy, Fz=-fz, Mx=mx, My=-my,
               Mz=-mz)
    iso = sae_to_iso_w(sae).iloc[0]
    assert (iso.Fx, iso.Fy, iso.Fz, iso.Mx, iso.My, iso.Mz, iso.alpha) == (
        fx, fy, fz, mx, my, mz, alpha)


def test_c_to_w_at_zero_camber_by_hand():
    w = c_to_w(100.0, -2000.0, 5000.0, 10.0, -20.0, 30.0, 0.0, 0.3)
    # forces equal; Mx_W = MxC - rl*Fy = 10 + 600; My_W = MyC + rl*Fx = -20 + 30
    assert w["Fx"] == 100.0 and w["Fy"] == -2000.0 and w["Fz"] == 5000.0
    assert w["Mx"] == pytest.approx(610.0, abs=1e-12)
    assert w["My"] == pytest.approx(10.0, abs=1e-12)
    assert w["Mz"] == 30.0


def test_c_to_w_lateral_force_lever_arm_sign():
    # A lateral force +Fy at the road acts on a lever rl below the hub: the hub sees
    # MxC = +rl*Fy, and the contact point sees no moment.
    w = c_to_w(0.0, 1000.0, 0.0, 0.3 * 1000.0, 0.0, 0.0, 0.0, 0.3)
    assert w["Mx"] == pytest.approx(0.0, abs=1e-12)
    # A forward force at the road gives the hub My = -rl*Fx (it pitches the wheel nose-down).
    w = c_to_w(1000.0, 0.0, 0.0, 0.0, -300.0, 0.0, 0.0, 0.3)
    assert w["My"] == pytest.approx(0.0, abs=1e-12)


def test_c_to_w_at_30_degrees_by_hand():
    c, s = math.sqrt(3) / 2, 0.5
    w = c_to_w(100.0, -2000.0, 5000.0, 10.0, -20.0, 30.0, math.pi / 6, 0.3)
    assert w["Fy"] == pytest.approx(-2000.0 * c - 5000.0 * s, rel=1e-14)   # -4232.05...
    assert w["Fy"] == pytest.approx(-4232.050807568877, rel=1e-14)
    assert w["Fz"] == pytest.approx(-1000.0 + 5000.0 * c, rel=1e-14)      # 3330.127...
    assert w["Mx"] == pytest.approx(610.0, rel=1e-14)                      # camber-free
    assert w["My"] == pytest.approx(-20.0 * c - 30.0 * s + 30.0 * c, rel=1e-14)
    assert w["My"] == pytest.approx(-6.339745962155614, rel=1e-12)
    assert w["Mz"] == pytest.approx(-10.0 + 30.0 * c + 15.0, rel=1e-14)   # 30.98...
    assert w["Mz"] == pytest.approx(30.98076211353316, rel=1e-14)


def test_c_to_w_equals_rotation_plus_lever_arm():
    rng = np.random.default_rng(5)
    fc, mc = rng.normal(size=(2, 3)) * 1000
    g, rl = 0.2, 0.31
    rot = np.array([[1, 0, 0], [0, math.cos(g), -math.sin(g)], [0, math.sin(g), math.cos(g)]])
    fw = rot @ fc
    d = rl * np.array([0.0, -math.sin(g), math.cos(g)])
    mw = rot @ mc + np.cross(d, fw)
    w = c_to_w(*fc, *mc, g, rl)
    np.testing.assert_allclose([w[k] for k in ("Fx", "Fy", "Fz")], fw, rtol=1e-13)
    np.testing.assert_allclose([w[k] for k in ("Mx", "My", "Mz")], mw, rtol=1e-12, atol=1e-9)


def test_flatplank_transform_is_c_to_w_of_the_hub_c_forces():
    rng = np.random.default_rng(7)
    gx1, gx2, gy, gz1, gz2 = rng.normal(size=(5, 20)) * 1000
    phw, php = rng.uniform(-0.1, 0.1, (2, 20))
    rl = rng.uniform(0.28, 0.32, 20)
    out = hub_to_contact(gx1, gx2, gy, gz1, gz2, phw, php, 0.0, rl, a=0.08, b=0.05)
    w = c_to_w(out["FxC"], out["FyC"], out["FzC"], out["MxC"], out["MyC"], out["MzC"],
               phw + php, rl)
    for key in ("Fx", "Fy", "Fz", "Mx", "My", "Mz"):
        np.testing.assert_allclose(out[key], w[key], rtol=1e-12, atol=1e-9, err_msg=key)


def test_to_iso_w_tydex_c_table():
    frame = _row(gamma=0.0, Fx=100.0, Fy=-2000.0, Fz=5000.0, Mx=10.0, My=-20.0, Mz=30.0)
    out = to_iso_w(frame, "TYDEX-C", loaded_radius=0.3).iloc[0]
    assert out.Mx == pytest.approx(610.0) and out.My == pytest.approx(10.0)
    assert frame.Mx.iloc[0] == 10.0
    assert to_iso_w(frame, "ISO-W").equals(frame)
    with pytest.raises(ValueError, match="loaded radius"):
        to_iso_w(frame, "TYDEX-C")
    with pytest.raises(ValueError, match="unknown axis system 'ISO'"):
        to_iso_w(frame, "ISO")
