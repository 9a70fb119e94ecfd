"""Flatplank raw runs: the hub -> contact-patch transform (docs/procedures.md), the reader."""
from __future__ import annotations

import math

import numpy as np
import pytest

from identify.core.errors import InputError
from identify.io.flatplank import FLATPLANK_COLUMNS, hub_to_contact, read_flatplank
from tests.measurement_cases import flatplank_channels, write_csv

A, B = 0.08, 0.05
# Gx1 = 100, Gx2 = 50, Gy = 200, Gz1 = 2000, Gz2 = 3000 N; r_l = 0.3 m:
# Kx = 150, Ky = 200, Kz = 5000; Tx = 2000*0.13 + 3000*0.05 = 410; Tz = 100*0.13 + 50*0.05 = 15.5
HUB = dict(Gx1=100.0, Gx2=50.0, Gy=200.0, Gz1=2000.0, Gz2=3000.0)
C_AXES = {"FxC": 150.0, "FyC": -200.0, "FzC": 5000.0, "MxC": -410.0, "MyC": 0.0, "MzC": 15.5}


def _transform(phi_wheel: float, phi_plank: float, psi: float = 0.0) -> dict:
    return hub_to_contact(**HUB, phi_wheel=phi_wheel, phi_plank=phi_plank, psi=psi,
                          loaded_radius=0.3, a=A, b=B)


def test_zero_camber_by_hand():
    out = _transform(0.0, 0.0, psi=0.02)
    expected = {"gamma": 0.0, "alpha": 0.02, "Fx": 150.0, "Fy": -200.0, "Fz": 5000.0,
                "Mx": -410.0 + 200.0 * 0.3,   # -350
                "My": 150.0 * 0.3,            # 45
                "Mz": 15.5, **C_AXES}
    for key, value in expected.items():
        assert out[key] == pytest.approx(value, rel=1e-14, abs=1e-12), key


# gamma = 30 deg: cos = 0.8660254037844386, sin = 0.5
GAMMA30 = {"Fy": -200.0 * 0.8660254037844386 - 2500.0,     # -2673.2050807568877
           "Fz": -100.0 + 5000.0 * 0.8660254037844386,     # 4230.127018922193
           "Mx": -350.0,
           "My": -15.5 * 0.5 + 45.0 * 0.8660254037844386,  # 31.22114317029974
           "Mz": 15.5 * 0.8660254037844386 + 45.0 * 0.5}   # 35.9233937586588


@pytest.mark.parametrize("phi_wheel,phi_plank", [
    (math.pi / 6, 0.0), (0.0, math.pi / 6), (math.pi / 12, math.pi / 12)],
    ids=["phi_wheel", "phi_plank", "both"])
def test_camber_by_hand_from_either_source(phi_wheel, phi_plank):
    out = _transform(phi_wheel, phi_plank)
    assert out["gamma"] == pytest.approx(math.pi / 6, rel=1e-15)
    assert GAMMA30["Fy"] == pytest.approx(-2673.2050807568877, rel=1e-15)
    assert GAMMA30["Fz"] == pytest.approx(4230.127018922193, rel=1e-15)
    assert GAMMA30["My"] == pytest.approx(31.22114317029974, rel=1e-14)
    assert GAMMA30["Mz"] == pytest.approx(35.9233937586588, rel=1e-14)
    for key, value in {**GAMMA30, **C_AXES, "Fx": 150.0}.items():
        assert out[key] == pytest.approx(value, rel=1e-13, abs=1e-12), key


def test_vectorised_over_samples():
    out = hub_to_contact(*(np.full(4, v) for v in HUB.values()), np.zeros(4),
                         np.array([0.0, 0.1, -0.1, 0.2]), np.zeros(4), 0.3, a=A, b=B)
    assert out["Fz"].shape == (4,) and out["MyC"].shape == (4,)
    assert out["Fz"][1] == pytest.approx(-200 * math.sin(0.1) + 5000 * math.cos(0.1))


def test_reader_converts_units_and_adds_conditions(tmp_path):
    ch = flatplank_channels(n=11, phi_plank=math.radians(5.0), seed=3)
    ch["phi_plank"] = np.degrees(ch["phi_plank"])
    ch["hub_z"] = ch["hub_z"] * 1000.0
    header = [f"{k} [mm]" if k == "hub_z" else k for k in ch]
    path = write_csv(tmp_path / "camber_p250_fz5000_s2_g5.csv", ch, header)
    out = read_flatplank(path, a=A, b=B, test="camber", units={"phi_plank": "deg"},
                         conditions={"pressure_Pa": 250000.0, "load_N": 5000.0,
                                     "start_position": 2})
    assert list(out.columns) == list(FLATPLANK_COLUMNS) + ["pressure_Pa", "load_N",
                                                           "start_position"]
    assert (out.run == "camber_p250_fz5000_s2_g5").all() and (out.test == "camber").all()
    np.testing.assert_allclose(out.gamma, math.radians(5.0), rtol=1e-14)
    np.testing.assert_allclose(out.hub_z, 0.02, rtol=1e-14)
    np.testing.assert_allclose(out.Fz, 5000.0, rtol=0.01)
    assert (out.start_position == 2).all()


def test_reader_flags_load_far_from_declared(tmp_path):
    path = write_csv(tmp_path / "parking.csv", flatplank_channels(load=3000.0))
    with pytest.raises(InputError, match=r"Fz: median contact load Fz 30\d\d\.\d* N is more than "
                                         r"15% from the declared 5000 N"):
        read_flatplank(path, a=A, b=B, test="parking", conditions={"load_N": 5000.0})
    # vertical runs sweep the load: not checked
    read_flatplank(path, a=A, b=B, test="vertical", conditions={"load_N": 5000.0})


def test_reader_flags_time_going_back(tmp_path):
    ch = flatplank_channels(n=6)
    ch["time"] = np.array([0.0, 1.0, 2.0, 1.5, 3.0, 4.0])
    path = write_csv(tmp_path / "run.csv", ch)
    with pytest.raises(InputError) as err:
        read_flatplank(path, a=A, b=B)
    assert str(err.value) == (f"{path}:5: time: time is not increasing: 1.5 after 2.0 "
                              "(1 such sample(s))")
