"""The simulated Flatplank rig: constants, the test physics it adds, and the hub transform inverse.

The forward transform of ``docs/procedures.md`` maps the five hub bridges to contact-patch
forces (ISO-W). :func:`bridges_from_contact` inverts it exactly, so a loader that applies the
forward transform to the written channels recovers the simulated contact-patch forces. The hub
cannot measure My independently: My = -Tz sin(gamma) + Fx rl cos(gamma) follows from the others.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from identify.core.serial import Serial

__all__ = ["Rig", "DEFAULT_RIG", "bridges_from_contact", "BRIDGES", "FLATPLANK_CHANNELS"]

#: The hub bridge channels [N].
BRIDGES = ("Gx1", "Gx2", "Gy", "Gz1", "Gz2")
#: Every channel of a Flatplank raw CSV, in file order (docs/measurement-folder.md).
FLATPLANK_CHANNELS = ("time", *BRIDGES, "plank_x", "wheel_angle", "psi", "hub_z", "phi_wheel",
                      "phi_plank", "loaded_radius")


@dataclass(frozen=True)
class Rig(Serial):
    """Flatplank constants and the shape of the effects the simulator gives each test.

    Attributes
    ----------
    hub_a, hub_b : float
        Hub geometry: Gx1-Gx2 bridge distance and Gx2 bridge to wheel centre plane [m].
    rolling_speed, stiffness_speed, vertical_speed : float
        Plank speed of rolling tests, plank speed of locked-hub tests, hub speed of the
        vertical test [m/s].
    turn_rate : float
        Turn-table rate of the parking test [rad/s].
    vertical_max_load : float
        Load at which the vertical test turns back [N].
    mu_x, mu_y : float
        Friction on the steel plank (saturation of the locked-hub tests) [-].
    linear_fraction : float
        Fraction of the saturation force up to which stiffness curves are exactly linear [-].
    parking_torque, parking_exponent, parking_pressure : float
        Saturation torque at Fz0 [N m], its load exponent and pressure coefficient:
        Ms = parking_torque (Fz/Fz0)^exponent (1 + parking_pressure dpi).
    parking_hysteresis : float
        Half height of the parking loop as a fraction of Ms [-].
    parking_range : float
        Turn-table amplitude (0 -> +range -> -range -> +range) [rad].
    start_spread : float
        Stiffness change between start positions, (1 + spread cos(2 pi k/n)) (mean 1) [-].
    ripple_fz, ripple_fy, ripple_fx, ripple_mz, ripple_mx : float
        Non-uniformity once per wheel revolution in rolling tests: Fz as a fraction of the
        load [-], the others in [N] and [N m]; identical in a run and its reference.
    vertical_hysteresis : float
        Unloading force deficit of the vertical test at zero deflection, as a fraction [-].
    relaxation_lengths, short_lengths : float
        Rolled distance of rolling runs in relaxation lengths, normal and too short [-].
    lead_in : float
        Standing time before the plank starts in rolling runs [s].
    wheel_camber_max : float
        Camber set by tilting the hub up to this angle; the rest tilts the plank [rad].
    """

    hub_a: float = 0.08
    hub_b: float = 0.05
    rolling_speed: float = 0.0475
    stiffness_speed: float = 0.002
    vertical_speed: float = 0.001
    turn_rate: float = np.deg2rad(1.0)
    vertical_max_load: float = 9000.0
    mu_x: float = 0.62
    mu_y: float = 0.58
    linear_fraction: float = 0.6
    parking_torque: float = 300.0
    parking_exponent: float = 1.5
    parking_pressure: float = -0.3
    parking_hysteresis: float = 0.15
    parking_range: float = np.deg2rad(20.0)
    start_spread: float = 0.005
    ripple_fz: float = 0.004
    ripple_fy: float = 15.0
    ripple_fx: float = 8.0
    ripple_mz: float = 0.8
    ripple_mx: float = 1.5
    vertical_hysteresis: float = 0.06
    relaxation_lengths: float = 7.0
    short_lengths: float = 1.5
    lead_in: float = 2.0
    wheel_camber_max: float = np.deg2rad(10.0)

    def start_factor(self, start: int, n_starts: int) -> float:
        """Stiffness factor of start position ``start`` (1-based); the mean over starts is 1."""
        if n_starts < 2:
            return 1.0
        return 1.0 + self.start_spread * np.cos(2 * np.pi * (start - 1) / n_starts)

    @staticmethod
    def start_phase(start: int, n_starts: int) -> float:
        """Angle of the tyre's marked start point for start position ``start`` [rad]."""
        return 2 * np.pi * (start - 1) / max(n_starts, 1)

    def camber_split(self, gamma):
        """(phi_wheel, phi_plank) [rad] that add up to ``gamma`` [rad]."""
        gamma = np.asarray(gamma, dtype=float)
        wheel = np.clip(gamma, -self.wheel_camber_max, self.wheel_camber_max)
        return wheel, gamma - wheel


DEFAULT_RIG = Rig()


def bridges_from_contact(fx, fy, fz, mx, mz, gamma, rl, hub_a, hub_b) -> dict[str, np.ndarray]:
    """Hub bridge signals that the Flatplank hub transform maps to the given contact forces.

    Parameters
    ----------
    fx, fy, fz : array_like
        Contact-patch forces, ISO-W [N].
    mx, mz : array_like
        Contact-patch moments, ISO-W [N m].
    gamma : array_like
        Camber phi_wheel + phi_plank [rad].
    rl : array_like
        Loaded radius [m].
    hub_a, hub_b : float
        Hub geometry [m].

    Returns
    -------
    dict of ndarray
        ``Gx1, Gx2, Gy, Gz1, Gz2`` [N] and the implied contact-patch ``My`` [N m].
    """
    g = np.asarray(gamma, dtype=float)
    c, s = np.cos(g), np.sin(g)
    fx, fy, fz = (np.asarray(v, dtype=float) for v in (fx, fy, fz))
    rl = np.asarray(rl, dtype=float)
    kx = fx
    ky = -c * fy - s * fz            # inverse of Fy = -Ky c - Kz s, Fz = -Ky s + Kz c
    kz = -s * fy + c * fz
    tx = ky * rl - np.asarray(mx, dtype=float)
    tz = (np.asarray(mz, dtype=float) - kx * rl * s) / c
    gx1 = (tz - kx * hub_b) / hub_a  # Tz = Gx1 (a + b) + Gx2 b with Gx1 + Gx2 = Kx
    gz1 = (tx - kz * hub_b) / hub_a
    return {"Gx1": gx1, "Gx2": kx - gx1, "Gy": ky, "Gz1": gz1, "Gz2": kz - gz1,
            "My": -tz * s + kx * rl * c}
