"""The tyres at the axles: the .tir evaluated by the vectorised forward model, mirrored on the
right-hand side, and the validity range the file states.

The steady-state, transient and ride modules see a tyre through :class:`AxleTyre`: the lateral
force and aligning moment of a left-hand wheel in ISO-W axes, plus the vertical stiffness,
vertical damping and relaxation length. :class:`MfTyre` implements it with
:func:`identify.model.evaluate.evaluate` (the function ``mfid eval`` runs), in
:data:`identify.model.modes.FIT_MODE` (no clipping to the file's ranges: the vehicle modules
flag every operating point outside them instead of hiding it). Tests give closed-form tyres.

The right-hand wheel is the mirror image of the left one, as vehicle tools mount a .tir on the
other side: Fy_right(alpha, gamma) = -Fy(-alpha, -gamma), Mz_right likewise, so that a car on
a straight road needs no steering to cancel the tyres' ply steer and conicity.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from identify.core.serial import Serial
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE

__all__ = ["AxleTyre", "MfTyre", "ValidityRange", "wheel_lateral"]


@dataclass(frozen=True)
class ValidityRange(Serial):
    """The ranges a .tir is valid in (its [*_RANGE] sections).

    Attributes
    ----------
    pressure_Pa, load_N, slip_angle_rad, camber_rad : (float, float)   (min, max)
    """

    pressure_Pa: tuple[float, float] = (-math.inf, math.inf)
    load_N: tuple[float, float] = (-math.inf, math.inf)
    slip_angle_rad: tuple[float, float] = (-math.inf, math.inf)
    camber_rad: tuple[float, float] = (-math.inf, math.inf)

    @classmethod
    def from_params(cls, P: Mapping[str, float]) -> ValidityRange:
        def pair(lo, hi):
            return (float(P.get(lo, -math.inf)), float(P.get(hi, math.inf)))
        return cls(pair("PRESMIN", "PRESMAX"), pair("FZMIN", "FZMAX"),
                   pair("ALPMIN", "ALPMAX"), pair("CAMMIN", "CAMMAX"))



class AxleTyre(Protocol):
    """What the vehicle modules need of a tyre (ISO-W axes, a left-hand wheel, SI)."""

    validity: ValidityRange

    def lateral(self, fz, alpha, gamma, p) -> tuple[np.ndarray, np.ndarray]:
        """Fy [N] and Mz [N m] at load ``fz`` [N], slip ``alpha`` [rad], inclination ``gamma``
        [rad], pressure ``p`` [Pa], free rolling (arrays broadcast)."""
        ...

    def vertical(self, fz, p, vx) -> tuple[np.ndarray, float]:
        """Vertical stiffness [N/m] at ``fz``, ``p``, speed ``vx`` [m/s]; vertical damping
        [N s/m] (0 when the file gives none)."""
        ...

    def relaxation_length(self, fz, gamma, p) -> np.ndarray:
        """Lateral relaxation length [m] at ``fz``, ``gamma``, ``p``."""
        ...


@dataclass(frozen=True)
class MfTyre:
    """A .tir's parameters evaluated by the vectorised Magic Formula.

    Attributes
    ----------
    params : mapping        ``TirFile.params()`` (SI)
    damping_given : bool    the file gives VERTICAL_DAMPING (else the ride uses 0)
    vx : float [m/s]        speed of the handling evaluations
    """

    params: Mapping[str, float]
    damping_given: bool = False
    vx: float = 100 / 3.6

    @property
    def validity(self) -> ValidityRange:
        return ValidityRange.from_params(self.params)

    def _eval(self, fz, alpha, gamma, p, vx=None):
        fz, alpha, gamma, p = np.broadcast_arrays(*(np.asarray(x, float)
                                                    for x in (fz, alpha, gamma, p)))
        shape = fz.shape
        out = evaluate(self.params, fz.ravel(), 0.0, alpha.ravel(), gamma.ravel(),
                       self.vx if vx is None else vx, p=p.ravel(), mode=FIT_MODE)
        return out, shape

    def lateral(self, fz, alpha, gamma, p):
        out, shape = self._eval(fz, alpha, gamma, p)
        return out["Fy"].reshape(shape), out["Mz"].reshape(shape)

    def vertical(self, fz, p, vx):
        out, shape = self._eval(fz, 0.0, 0.0, p, vx)
        damping = float(self.params.get("VERTICAL_DAMPING", 0.0)) if self.damping_given else 0.0
        return out["Cz"].reshape(shape), damping

    def relaxation_length(self, fz, gamma, p):
        out, shape = self._eval(fz, 0.0, gamma, p)
        return out["sigmay"].reshape(shape)


def wheel_lateral(tyre: AxleTyre, fz, alpha, side, camber, p):
    """Lateral force and aligning moment of wheels in the vehicle's sense.

    Parameters
    ----------
    fz : array [N]
    alpha : array [rad]      slip angle, positive when the wheel pushes the car to the left
    side : array             +1 left-hand wheel, -1 right-hand wheel (mirrored tyre)
    camber : array [rad]     static camber, negative with the top towards the car
    p : array [Pa]

    Returns
    -------
    fy : ndarray [N]         force on the car, positive to the left
    mz : ndarray [N m]       moment about the vertical (up), positive anticlockwise

    Notes
    -----
    A left wheel with camber c has ISO inclination -c; a right wheel +c, which mirrored is
    -c again: both wheels evaluate the file at gamma = -c. ISO slip alpha_iso = -alpha on the
    left; the mirrored right wheel evaluates +alpha and changes the signs of Fy and Mz.
    """
    side = np.asarray(side, float)
    fy, mz = tyre.lateral(fz, -side * np.asarray(alpha, float), -np.asarray(camber, float), p)
    return side * fy, side * mz
