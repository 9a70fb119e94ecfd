"""Tyre size designations -> .tir dimensions (identify.core.tyre_size)."""
from __future__ import annotations

import pytest

from identify.core.tyre_size import parse_tyre_size

IN = 0.0254


@pytest.mark.parametrize("text", ["225/50 R17", "225/50R17", "P225/50R17 94V", "225/50 ZR17",
                                  " 225 / 50 R 17 "])
def test_metric_size(text):
    s = parse_tyre_size(text)
    assert s.width_m == pytest.approx(0.225, rel=1e-15)
    assert s.aspect_ratio == pytest.approx(0.50, rel=1e-15)
    assert s.rim_radius_m == pytest.approx(17 * IN / 2, rel=1e-15)   # 0.2159 m
    # nominal unloaded radius 215.9 + 112.5 mm
    assert s.unloaded_radius_m == pytest.approx(0.3284, rel=1e-12)


@pytest.mark.parametrize("text", ["20.5x7.0-13", "20.5X7.0 R13", "20.5 x 7.0 - 13"])
def test_flotation_size(text):
    s = parse_tyre_size(text)
    assert s.width_m == pytest.approx(7.0 * IN, rel=1e-15)
    assert s.rim_radius_m == pytest.approx(6.5 * IN, rel=1e-15)
    assert s.aspect_ratio == pytest.approx(3.75 / 7.0, rel=1e-15)
    assert s.unloaded_radius_m == pytest.approx(10.25 * IN, rel=1e-12)  # half of 20.5 in


@pytest.mark.parametrize("text", ["", "big tyre", "225/50", "10x7-13", "13x7.0-20"])
def test_not_a_size(text):
    assert parse_tyre_size(text) is None
