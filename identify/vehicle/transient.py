"""Transient handling (ISO 7401, linear range): the single-track model with tyre lag.

States x = (v, r, Fy_front, Fy_rear): lateral velocity [m/s], yaw rate [rad/s] and the two
axle forces [N], which follow their steady-state value through a first-order lag of time
constant sigma / V (the relaxation length of the axle's tyres):

    m (dv/dt + V r) = Fy_f + Fy_r
    Iz dr/dt        = a Fy_f - b Fy_r
    (sigma_f / V) dFy_f/dt + Fy_f = C_f (delta - (v + a r) / V)
    (sigma_r / V) dFy_r/dt + Fy_r = C_r (-(v - b r) / V)

delta is the road-wheel steer angle. Outputs: yaw rate r and lateral acceleration
ay = (Fy_f + Fy_r) / m. In steady state r/delta = V / (l + K V^2) with
K = (m / l)(b / C_f - a / C_r), whatever the relaxation lengths. The natural frequency and
damping ratio are those of the eigenvalue pair of smallest magnitude (the body's yaw/side-slip
mode; the lag modes lie near -V/sigma).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["SingleTrack", "FrequencyResponse", "frequency_response", "FREQUENCIES_HZ"]

FREQUENCIES_HZ = np.geomspace(0.05, 4.0, 120)
"""Frequencies of the frequency responses [Hz] (ISO 7401 random steer covers 0-2 Hz at least)."""


@dataclass(frozen=True)
class SingleTrack:
    """The linear single-track model of one setting.

    Attributes
    ----------
    mass_kg, iz_kgm2 : float [kg], [kg m^2]
    a, b : float [m]                  centre of gravity to front / rear axle
    c_front, c_rear : float [N/rad]   axle cornering stiffnesses
    sigma_front, sigma_rear : float [m]  relaxation lengths (0: no lag)
    speed : float [m/s]
    """

    mass_kg: float
    iz_kgm2: float
    a: float
    b: float
    c_front: float
    c_rear: float
    sigma_front: float
    sigma_rear: float
    speed: float

    @property
    def wheelbase(self) -> float:
        return self.a + self.b

    @property
    def understeer_gradient(self) -> float:
        """K = (m/l)(b/C_f - a/C_r) [rad/(m/s^2)]."""
        return self.mass_kg / self.wheelbase * (self.b / self.c_front - self.a / self.c_rear)

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A, B, C) of dx/dt = A x + B delta, y = C x with y = (r, ay); the lag rows become
        algebraic in the limit sigma -> 0, approached here with sigma >= 1 mm."""
        m, iz, a, b, V = self.mass_kg, self.iz_kgm2, self.a, self.b, self.speed
        cf, cr = self.c_front, self.c_rear
        tf = max(self.sigma_front, 1e-3) / V
        tr = max(self.sigma_rear, 1e-3) / V
        A = np.array([
            [0.0, -V, 1 / m, 1 / m],
            [0.0, 0.0, a / iz, -b / iz],
            [-cf / (V * tf), -cf * a / (V * tf), -1 / tf, 0.0],
            [-cr / (V * tr), cr * b / (V * tr), 0.0, -1 / tr]])
        B = np.array([0.0, 0.0, cf / tf, 0.0])
        C = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1 / m, 1 / m]])
        return A, B, C

    def response(self, f_hz) -> tuple[np.ndarray, np.ndarray]:
        """Complex yaw-rate and lateral-acceleration responses to road-wheel steer at
        frequencies ``f_hz`` [Hz]: r/delta [1/s] and ay/delta [m/s^2/rad]."""
        A, B, C = self.matrices()
        s = 2j * np.pi * np.asarray(f_hz, float)
        eye = np.eye(4)
        x = np.linalg.solve(s[:, None, None] * eye[None] - A[None], np.broadcast_to(
            B, (len(s), 4))[..., None])[..., 0]
        y = x @ C.T
        return y[:, 0], y[:, 1]

    def steady_state_yaw_gain(self) -> float:
        """r/delta at zero frequency [1/s] (-C A^-1 B)."""
        A, B, C = self.matrices()
        return float(-(C @ np.linalg.solve(A, B))[0])

    def body_mode(self) -> tuple[float, float, bool]:
        """Natural frequency [Hz], damping ratio [-] of the eigenvalue pair of smallest
        magnitude, and whether every eigenvalue has a negative real part."""
        A, _, _ = self.matrices()
        lam = np.linalg.eigvals(A)
        stable = bool(np.all(lam.real < 0))
        pair = lam[np.argsort(np.abs(lam))[:2]]
        wn = math.sqrt(abs((pair[0] * pair[1]).real))
        zeta = -float((pair[0] + pair[1]).real) / (2 * wn) if wn > 0 else math.nan
        return wn / (2 * math.pi), zeta, stable


@dataclass(frozen=True)
class FrequencyResponse:
    """Gains and phases of one setting (arrays over ``f_hz``).

    Attributes
    ----------
    f_hz : ndarray [Hz]
    yaw_gain : ndarray [1/s]              |r / delta| (road-wheel steer)
    yaw_phase_deg : ndarray [deg]         phase of r / delta (negative: r lags)
    ay_gain : ndarray [m/s^2/rad]
    ay_phase_deg : ndarray [deg]
    """

    f_hz: np.ndarray
    yaw_gain: np.ndarray
    yaw_phase_deg: np.ndarray
    ay_gain: np.ndarray
    ay_phase_deg: np.ndarray


def _phase(h: np.ndarray) -> np.ndarray:
    return np.degrees(np.unwrap(np.angle(h)))


def frequency_response(model: SingleTrack, f_hz=FREQUENCIES_HZ) -> FrequencyResponse:
    """The yaw-rate and lateral-acceleration responses of ``model`` at ``f_hz`` [Hz] (phases
    unwrapped from the lowest frequency, which must be well below the body mode)."""
    f_hz = np.asarray(f_hz, float)
    r, ay = model.response(f_hz)
    return FrequencyResponse(f_hz, np.abs(r), _phase(r), np.abs(ay), _phase(ay))


def phase_delay_deg(model: SingleTrack, f_hz: float = 1.0) -> tuple[float, float]:
    """Phase delays [deg] of yaw rate and lateral acceleration behind the steer at ``f_hz``
    (positive: the response lags), unwrapped along a frequency line from 0.01 Hz."""
    fr = frequency_response(model, np.linspace(0.01, f_hz, 200))
    return float(-fr.yaw_phase_deg[-1]), float(-fr.ay_phase_deg[-1])
