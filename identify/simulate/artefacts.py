"""Measurement artefacts: the settings, and the vectorised signal pieces that realise them.

All functions act on whole arrays (no loop over samples). Random numbers come only from the
generator passed in (``numpy.random.Generator``); nothing seeds a global state.
"""
from __future__ import annotations

from dataclasses import dataclass
from zlib import crc32

import numpy as np
from scipy.signal import lfilter

from identify.core.serial import Serial

__all__ = ["Artefacts", "run_rng", "ar1_unit", "add_noise", "saturate", "stick_slip",
           "startup_transient"]


@dataclass(frozen=True)
class Artefacts(Serial):
    """What the simulator does to otherwise ideal data.

    Attributes
    ----------
    seed : int
        Seed of every random number (noise only).
    noise : float
        Noise standard deviation as a fraction of each channel's RMS over its run [-].
    ar1_rho : float
        Lag-one correlation of the noise along each run (0 = white) [-].
    transients : bool
        Start-up slack and a decaying oscillation at the start of locked-hub and parking runs.
    stick_slip : bool
        Saw-tooth stick-slip once a locked-hub or parking run saturates.
    asymmetry : float
        Camber-induced Fy, Mz, Mx at negative camber scaled by (1 + asymmetry), as a hub
        calibration error would (the truth stays symmetric) [-].
    short_relaxation : bool
        The relaxation runs of the cell with the longest relaxation length stop before steady
        state.
    """

    seed: int = 0
    noise: float = 0.01
    ar1_rho: float = 0.0
    transients: bool = True
    stick_slip: bool = True
    asymmetry: float = 0.0
    short_relaxation: bool = True

    def __post_init__(self) -> None:
        if not self.noise >= 0:
            raise ValueError(f"noise must be >= 0, not {self.noise!r}")
        if not -1 < self.ar1_rho < 1:
            raise ValueError(f"ar1_rho must lie in (-1, 1), not {self.ar1_rho!r}")
        if not self.asymmetry > -1:
            raise ValueError(f"asymmetry must be > -1, not {self.asymmetry!r}")


def run_rng(seed: int, run_id: str) -> np.random.Generator:
    """The generator of one run: depends only on the seed and the run id."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), crc32(run_id.encode())]))


def ar1_unit(rng: np.random.Generator, n: int, rho: float) -> np.ndarray:
    """Stationary AR(1) series of unit variance: e_k = rho e_(k-1) + sqrt(1 - rho^2) w_k."""
    w = rng.standard_normal(n)
    if rho == 0 or n < 2:
        return w
    out = np.empty(n)
    out[0] = w[0]
    out[1:], _ = lfilter([np.sqrt(1 - rho ** 2)], [1.0, -rho], w[1:], zi=[rho * w[0]])
    return out


def add_noise(rng: np.random.Generator, columns: dict[str, np.ndarray], names, level: float,
              rho: float) -> dict[str, np.ndarray]:
    """Return a copy of ``columns`` with noise of ``level`` x RMS added to each of ``names``."""
    out = dict(columns)
    if level <= 0:
        return out
    for name in names:
        x = np.asarray(columns[name], dtype=float)
        rms = np.sqrt(np.mean(x ** 2)) if x.size else 0.0
        out[name] = x + level * rms * ar1_unit(rng, x.size, rho)
    return out


def saturate(f, f_sat, linear_fraction):
    """Exactly linear up to ``linear_fraction * f_sat``, then a C1 tanh approach to ``f_sat``."""
    f = np.asarray(f, dtype=float)
    f_sat = np.asarray(f_sat, dtype=float)
    f1 = linear_fraction * f_sat
    span = f_sat - f1
    mag = np.abs(f)
    over = f1 + span * np.tanh((mag - f1) / span)
    return np.sign(f) * np.where(mag <= f1, mag, over)


def stick_slip(travel, level, amplitude, wavelength, onset=0.97):
    """Saw-tooth stick-slip on a saturated force: zero until ``|level| >= onset``.

    Parameters
    ----------
    travel : array_like
        Monotonic travel along the run (plank or turn-table path length) [m or rad].
    level : array_like
        Clean force as a fraction of its saturation value [-].
    amplitude : float
        Drop at each slip as a fraction of the saturation force [-].
    wavelength : float
        Travel per stick-slip cycle (unit of ``travel``).

    Returns
    -------
    ndarray
        Multiplicative reduction factor in [1 - amplitude, 1].
    """
    travel = np.asarray(travel, dtype=float)
    on = np.abs(np.asarray(level, dtype=float)) >= onset
    if not on.any():
        return np.ones_like(travel)
    start = travel[np.argmax(on)]
    phase = np.mod((travel - start) / wavelength, 1.0)
    ramp = np.clip((travel - start) / wavelength, 0.0, 1.0)
    return np.where(on, 1.0 - amplitude * ramp * (1.0 - phase), 1.0)


def startup_transient(x, slack, amplitude, decay, period):
    """Start-up effects of a locked-hub run as functions of the plank travel ``x`` [m].

    Returns
    -------
    (ndarray, ndarray)
        Effective displacement (the rig's slack taken up: x - slack (1 - exp(-x/slack))) [m],
        and a decaying oscillation amplitude exp(-x/decay) sin(2 pi x/period) [-] to scale by
        the saturation force.
    """
    x = np.asarray(x, dtype=float)
    u = x - slack * (1 - np.exp(-x / slack))
    osc = amplitude * np.exp(-x / decay) * np.sin(2 * np.pi * x / period)
    return u, osc
