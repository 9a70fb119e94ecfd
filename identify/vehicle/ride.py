"""Ride: a quarter car on a random road of an ISO 8608 class.

The road's displacement spectral density over spatial frequency n [cycles/m] is

    Gd(n) = Gd(n0) (n / n0)^-2,    n0 = 0.1 cycles/m,   0.011 <= n <= 2.83 cycles/m

with Gd(n0) = 16e-6 m^3 for class A and four times more per class (B 64e-6, C 256e-6 ...,
the classes' geometric means). A profile is a sum of harmonics at n_k = k dn with amplitudes
sqrt(2 Gd(n_k) dn) and phases drawn from a seeded generator, driven over at speed V (temporal
frequency f = n V). The quarter car (body m_s, wheel m_u, spring k_s, damper c_s, tyre
vertical stiffness k_t and damping c_t, point contact) is linear, so each harmonic's response
is exact; the responses are summed over one period of the profile (1/dn metres) and their RMS
taken. Because only the phases are random, the RMS values do not depend on the seed (the mean
square of a sum of harmonics is the sum of their mean squares over a whole period): the seed
fixes the profile, the figures are the road class's.

Outputs: body (sprung-mass) vertical acceleration RMS [m/s^2] and the RMS of the dynamic
wheel load (the tyre force about its static value) [N].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ROAD_CLASSES", "RoadProfile", "road_profile", "QuarterCarModel", "RideResult",
           "ride_response", "transfer"]

ROAD_CLASSES = {c: 16e-6 * 4.0 ** i for i, c in enumerate("ABCDEFGH")}
"""ISO 8608 class -> Gd(n0) [m^3] at n0 = 0.1 cycles/m (geometric mean of the class)."""
N0 = 0.1
N_MIN, N_MAX = 0.011, 2.83
DN = 0.001


@dataclass(frozen=True)
class RoadProfile:
    """A seeded ISO 8608 profile as harmonics.

    Attributes
    ----------
    road_class : str
    n : ndarray [cycles/m]       spatial frequencies (multiples of ``dn``)
    amplitude : ndarray [m]
    phase : ndarray [rad]
    dn : float [cycles/m]        spacing; the profile repeats every 1/dn metres
    seed : int
    """

    road_class: str
    n: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    dn: float
    seed: int

    def elevation(self, x) -> np.ndarray:
        """Road elevation [m] at distances ``x`` [m]."""
        x = np.asarray(x, float)
        return (self.amplitude * np.cos(2 * np.pi * self.n * x[..., None] + self.phase)).sum(-1)


def road_profile(road_class: str = "B", seed: int = 0, dn: float = DN) -> RoadProfile:
    """The harmonics of an ISO 8608 road of ``road_class`` (A-H) with phases from
    ``numpy.random.default_rng(seed)``."""
    if road_class not in ROAD_CLASSES:
        raise ValueError(f"road class {road_class!r} is not an ISO 8608 class (A-H)")
    k = np.arange(int(np.ceil(N_MIN / dn)), int(np.floor(N_MAX / dn)) + 1)
    n = k * dn
    gd = ROAD_CLASSES[road_class] * (n / N0) ** -2
    phase = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, n.size)
    return RoadProfile(road_class, n, np.sqrt(2 * gd * dn), phase, dn, seed)


@dataclass(frozen=True)
class QuarterCarModel:
    """The linear quarter car: masses [kg], spring and tyre stiffness [N/m], dampers
    [N s/m]."""

    sprung_mass: float
    unsprung_mass: float
    spring: float
    damper: float
    tyre_stiffness: float
    tyre_damping: float = 0.0


def transfer(q: QuarterCarModel, f_hz) -> tuple[np.ndarray, np.ndarray]:
    """Complex responses to road elevation at ``f_hz`` [Hz]: body acceleration per metre
    [1/s^2] and dynamic wheel load per metre [N/m]."""
    w = 2 * np.pi * np.asarray(f_hz, float)
    s = 1j * w
    ms, mu, ks, cs, kt, ct = (q.sprung_mass, q.unsprung_mass, q.spring, q.damper,
                              q.tyre_stiffness, q.tyre_damping)
    zs_k = ks + cs * s
    zt = kt + ct * s
    # [ms s^2 + zs_k, -zs_k; -zs_k, mu s^2 + zs_k + zt] [xs; xu] = [0; zt] zr
    d11 = ms * s ** 2 + zs_k
    d22 = mu * s ** 2 + zs_k + zt
    det = d11 * d22 - zs_k ** 2
    xs = zs_k * zt / det
    xu = d11 * zt / det
    return s ** 2 * xs, zt * (1.0 - xu)


@dataclass(frozen=True)
class RideResult:
    """RMS values of one corner on one road.

    Attributes
    ----------
    body_acceleration_rms : float [m/s^2]
    wheel_load_rms : float [N]        dynamic wheel load about the static load
    tyre_stiffness : float [N/m]
    tyre_damping : float [N s/m]
    body_frequency_hz, wheel_frequency_hz : float [Hz]   undamped, of the two masses
    """

    body_acceleration_rms: float
    wheel_load_rms: float
    tyre_stiffness: float
    tyre_damping: float
    body_frequency_hz: float
    wheel_frequency_hz: float


def ride_response(q: QuarterCarModel, road: RoadProfile, speed: float) -> RideResult:
    """Drive ``q`` over one period of ``road`` at ``speed`` [m/s]: RMS of the sampled
    responses (every harmonic's response summed, sampled at 4x the highest harmonic index)."""
    f = road.n * speed
    acc, load = transfer(q, f)
    k = np.rint(road.n / road.dn).astype(int)
    n_t = 4 * int(k.max()) + 4
    out = []
    for h in (acc, load):
        spec = np.zeros(n_t // 2 + 1, complex)
        spec[k] = 0.5 * n_t * road.amplitude * h * np.exp(1j * road.phase)
        out.append(float(np.sqrt(np.mean(np.fft.irfft(spec, n_t) ** 2))))
    keq = q.spring * q.tyre_stiffness / (q.spring + q.tyre_stiffness)
    fb = np.sqrt(keq / q.sprung_mass) / (2 * np.pi)
    fw = np.sqrt((q.spring + q.tyre_stiffness) / q.unsprung_mass) / (2 * np.pi)
    return RideResult(out[0], out[1], q.tyre_stiffness, q.tyre_damping, float(fb), float(fw))
