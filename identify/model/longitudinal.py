"""Longitudinal force: pure slip Fx0 (4.E9-4.E18 with pressure) and combined Fx (4.E50-4.E57).

Pure vectorised functions of an :class:`OperatingState` and a parameter mapping; no I/O. ``xp``
is the array module (numpy by default; jax.numpy for the MF stages' exact derivatives,
identify.fit.mf.jacobian).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from identify.model.state import EPS, OperatingState, sgn1


@dataclass(frozen=True)
class PureLongitudinal:
    """Fx0 and the pieces other equations reuse.

    Attributes
    ----------
    fx0 : ndarray [N]
    mux : ndarray [-]   friction coefficient (0 where Fz = 0)
    kxk : ndarray [N]   longitudinal slip stiffness dFx0/dkappa
    """

    fx0: np.ndarray
    mux: np.ndarray
    kxk: np.ndarray


def magic_sine(b, c, d, e, x, xp=np):
    """D*sin(C*atan(B*x - E*(B*x - atan(B*x)))): the Magic Formula in sine form."""
    bx = b * x
    return d * xp.sin(c * xp.arctan(bx - e * (bx - xp.arctan(bx))))


def magic_cosine(b, c, e, x, xp=np):
    """cos(C*atan(B*x - E*(B*x - atan(B*x)))): the weighting-function shape."""
    bx = b * x
    return xp.cos(c * xp.arctan(bx - e * (bx - xp.arctan(bx))))


def fx0(P: Mapping[str, float], s: OperatingState, xp=np) -> PureLongitudinal:
    """Pure longitudinal slip force Fx0 [N] (docs/model.md, section 4)."""
    dfz, dpi, fz = s.dfz, s.dpi, s.fz
    cx = P["PCX1"] * P["LCX"]
    mux = ((P["PDX1"] + P["PDX2"] * dfz) * (1 + P["PPX3"] * dpi + P["PPX4"] * dpi ** 2)
           * (1 - P["PDX3"] * s.gamma ** 2) * P["LMUX"])
    mux = xp.where(fz == 0, 0.0, mux)
    dx = mux * fz
    kxk = (fz * (P["PKX1"] + P["PKX2"] * dfz) * xp.exp(P["PKX3"] * dfz)
           * (1 + P["PPX1"] * dpi + P["PPX2"] * dpi ** 2) * P["LKX"])
    bx = kxk / (cx * dx + EPS * sgn1(dx, xp))
    shx = (P["PHX1"] + P["PHX2"] * dfz) * P["LHX"] * s.ws
    svx = fz * (P["PVX1"] + P["PVX2"] * dfz) * P["LVX"] * P["LMUX"] * s.ws
    kx = s.kappa + shx
    ex = ((P["PEX1"] + P["PEX2"] * dfz + P["PEX3"] * dfz ** 2)
          * (1 - P["PEX4"] * xp.sign(kx)) * P["LEX"])
    if s.mode.limits:
        ex = xp.minimum(ex, 1.0)
    f = magic_sine(bx, cx, dx, ex, kx, xp) + svx
    f = xp.where(s.vx_u < 0, -f, f)
    return PureLongitudinal(fx0=f, mux=mux, kxk=kxk)


def gx_alpha(P: Mapping[str, float], s: OperatingState, xp=np) -> np.ndarray:
    """Combined-slip weighting G_x,alpha [-] that multiplies Fx0 (docs/model.md, section 6)."""
    cxa = P["RCX1"]
    exa = P["REX1"] + P["REX2"] * s.dfz
    if s.mode.limits:
        exa = xp.minimum(exa, 1.0)
    shxa = P["RHX1"]
    bxa = ((P["RBX1"] + P["RBX3"] * s.gamma_star ** 2) * xp.cos(xp.arctan(P["RBX2"] * s.kappa))
           * P["LXAL"])
    alpha_s = s.alpha_star + shxa
    return magic_cosine(bxa, cxa, exa, alpha_s, xp) / magic_cosine(bxa, cxa, exa, shxa, xp)
