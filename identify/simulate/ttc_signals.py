"""The measured channels of a simulated TTC run: drift, temperatures, the model, noise, units.

From the per-sample set points (:mod:`identify.simulate.ttc_plan`) to the TTC channels in the
file's units and SAE axes:

- drift: load, speed and camber wander about their set points (slow AR(1), rho = 0.999); the
  wheel's eccentricity adds a once-per-revolution load ripple (0.8 % of Fz);
- temperatures: the tread centre follows a first-order lag (10 s) towards a target per segment
  kind (70 degC in the warm-up, 55 degC rolling, ambient while the tyre is lifted); the
  inflation gas follows the tread at 20 % of its rise with a 60 s lag, and the pressure, set
  cold at the end of each pressure change, rises with the gas temperature (ideal gas,
  constant volume: a few kPa);
- the Magic Formula (identify.model through :class:`~identify.simulate.model.TyreModel`) at
  the actual conditions gives Fx, Fy, Mx, Mz, the wheel speed (omega = (1 + kappa) Vx / Re),
  the loaded radius;
- relaxation (optional, ``relaxation`` [m], default 0: none): the tyre builds its lateral
  force over a rolling distance, so the model sees the slip angle through a first-order lag
  of that length (a time constant relaxation / Vx, Vx the run's median rolling speed) while
  the SA channel records the slip angle set; a triangle sweep then draws the up- and
  down-sweep branches of a real machine's force loop (each ~0.25 deg behind the angle set at
  0.5 m, 40 kph and the generator's 5.1-6.3 deg/s). The slip ratio is not lagged;
- noise: AR(1) of lag-one correlation ``ar1`` and a standard deviation of ``noise`` times each
  channel's RMS (forces, moments, slip, camber, speeds), at least 0.001 on the slip ratios SL
  and SR (so a cornering run's SL scatters about 0 as a real one does); fixed levels on
  pressure (0.3 kPa), radii (0.5 mm) and temperatures (0.2 K) at ``noise = 0.01``, in
  proportion otherwise. The channels of the operating conditions the model is evaluated at
  (:data:`INPUT_CHANNELS`: slip angle and ratios, camber, load, speeds) can take their own
  level ``input_noise`` (a rig whose slip channels are cleaner or noisier than its load
  cells); their floor on SL and SR scales with it.

All of it is vectorised over the samples.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from identify.core.units import to_si
from identify.io.ttc.files import TTC_CHANNELS
from identify.model.modes import TRAILER_MODE
from identify.simulate.artefacts import ar1_unit
from identify.simulate.model import TyreModel
from identify.simulate.ttc_plan import KIND_CODES, RATE, Programme

__all__ = ["AMBIENT_C", "INPUT_CHANNELS", "actual_conditions", "lagged_slip", "to_file_units",
           "ttc_channels"]

#: Ambient temperature [degC].
AMBIENT_C = 25.0
_P_ATM = 101325.0
#: Least noise of the slip-ratio channels at ``noise = 0.01`` [-]: a real cornering run's SL
#: scatters about 0 (wheel-speed and radius noise), it is never exactly 0.
SLIP_FLOOR = {"SL": 1e-3, "SR": 1e-3}
#: The channels of the operating conditions (slip angle and ratios, camber, load, speeds): their
#: noise is an error in the model's inputs, not in the measured forces.
INPUT_CHANNELS = ("SA", "SL", "SR", "IA", "FZ", "V", "N")
_TARGET_C = {"start": AMBIENT_C, "pressure_change": AMBIENT_C, "warmup": 70.0,
             "transition": 55.0, "sweep": 55.0}


def _lag(x: np.ndarray, tau: float, x0: float) -> np.ndarray:
    """First-order lag of time constant ``tau`` [s] at :data:`RATE`, starting from ``x0``."""
    a = 1.0 / (1.0 + tau * RATE)
    out, _ = lfilter([a], [1.0, -(1.0 - a)], x, zi=[(1.0 - a) * x0])
    return out


def actual_conditions(prog: Programme, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """What the machine actually ran: drifting load, speed, camber, pressure; temperatures.

    Returns arrays ``fz`` [N], ``vx`` [m/s], ``gamma``, ``alpha`` [rad], ``kappa`` [-], ``p``
    [Pa], ``t_centre`` (tread centre temperature) [degC], ``t_gas`` [degC] and ``kind``.
    """
    sp = prog.arrays()
    n = sp["fz"].size
    slow = {k: ar1_unit(rng, n, 0.999) for k in ("fz", "vx", "gamma")}
    kinds = {code: name for name, code in KIND_CODES.items()}
    target = np.array([_TARGET_C[kinds[c]] for c in range(len(kinds))])[sp["kind"]]
    t_centre = _lag(target, 10.0, AMBIENT_C)
    t_gas = AMBIENT_C + 0.2 * (_lag(t_centre, 60.0, AMBIENT_C) - AMBIENT_C)
    # the pressure is set (cold) where a segment says so: scale by the gas temperature since
    ref = np.zeros(n, dtype=int)
    for seg in prog.segments:
        if seg.get("set_pressure"):
            ref[seg["stop"] - 1] = seg["stop"] - 1
    ref = np.maximum.accumulate(ref)
    kelvin = t_gas + 273.15
    p = (sp["p"] + _P_ATM) * kelvin / kelvin[ref] - _P_ATM
    for seg in prog.segments:  # the pressure ramps start from what the gauge read
        if seg.get("set_pressure"):
            a, b = seg["start"], seg["stop"]
            p[a:b] = np.linspace(p[a - 1], sp["p"][b - 1], b - a)
    fz = sp["fz"] * (1.0 + 0.01 * slow["fz"])
    return {"fz": fz, "vx": sp["vx"] + 0.08 * slow["vx"] * (sp["vx"] > 1.0),
            "gamma": sp["gamma"] + np.deg2rad(0.03) * slow["gamma"], "alpha": sp["alpha"],
            "kappa": sp["kappa"], "p": p, "t_centre": t_centre, "t_gas": t_gas,
            "kind": sp["kind"]}


def lagged_slip(alpha: np.ndarray, vx: np.ndarray, relaxation: float) -> np.ndarray:
    """The slip angle the tyre sees [rad]: ``alpha`` [rad] through a first-order lag of
    ``relaxation`` [m] rolling distance at the median of ``vx`` [m/s] over the rolling
    samples (vx > 1 m/s; see module); ``alpha`` itself for a relaxation of 0."""
    rolling = vx[vx > 1.0]
    if relaxation <= 0 or rolling.size == 0:
        return alpha
    # exact for a slip angle linear between samples (first-order hold): a ramp lags by
    # exactly relaxation / Vx, where the plain recursion y = a y + (1 - a) x lags half a
    # sample less (0.04 s instead of 0.045 s at 0.5 m and 40 kph)
    n_tau = relaxation / float(np.median(rolling)) * RATE  # the time constant in samples
    a = float(np.exp(-1.0 / n_tau))
    b0 = 1.0 - n_tau * (1.0 - a)
    b1 = n_tau * (1.0 - a) - a
    return lfilter([b0, b1], [1.0, -a], alpha, zi=[(1.0 - b0) * alpha[0]])[0]


def ttc_channels(model: TyreModel, act: dict[str, np.ndarray], run_number: int, *,
                 rng: np.random.Generator, noise: float, ar1: float,
                 relaxation: float = 0.0,
                 input_noise: float | None = None) -> dict[str, np.ndarray]:
    """The TTC channels in SI units and SAE axes (temperatures in degC), noise added:
    ``noise`` on every channel, ``input_noise`` instead on :data:`INPUT_CHANNELS` (None: the
    same ``noise``), each a fraction of the channel's RMS [-].

    The eccentricity ripple multiplies the load before the model is evaluated, so the forces
    carry it as a real wheel's would; the model sees the slip angle through the
    ``relaxation`` [m] lag (:func:`lagged_slip`), the SA channel the slip angle set.
    """
    vx = act["vx"]
    args = {"alpha": lagged_slip(act["alpha"], vx, relaxation), "gamma": act["gamma"],
            "kappa": act["kappa"],
            "vx": np.maximum(vx, 0.05), "mode": TRAILER_MODE}
    # the wheel's angle (from its speed without the ripple) gives the ripple's phase
    theta = np.cumsum(model.mf(np.maximum(act["fz"], 1.0), act["p"] / 1e5, **args)["omega"])
    fz = np.maximum(act["fz"] * (1.0 + 0.008 * np.sin(theta / RATE + 0.7)), 1.0)
    out = model.mf(fz, act["p"] / 1e5, **args)
    omega = out["omega"]
    rl = out["Rl"] if "Rl" in out and np.isfinite(out["Rl"]).all() else \
        model.loaded_radius(fz, act["p"] / 1e5)
    with np.errstate(divide="ignore", invalid="ignore"):
        re = np.where(vx > 1.0, vx / omega, out["Re"])
        sr = np.where(vx > 1.0, omega * rl / vx - 1.0, 0.0)
    t_c = act["t_centre"]
    heat = (t_c - AMBIENT_C) / 30.0
    gamma_deg = np.rad2deg(act["gamma"])
    ch = {
        "ET": np.arange(vx.size) / RATE, "V": vx, "N": omega,
        "SA": -act["alpha"], "IA": act["gamma"], "RL": rl, "RE": re, "P": act["p"],
        "FX": out["Fx"], "FY": -out["Fy"], "FZ": -fz, "MX": out["Mx"], "MZ": -out["Mz"],
        "RST": AMBIENT_C + 5.0 + 0.5 * ar1_unit(rng, vx.size, 0.9999),
        "TSTI": t_c + 1.5 * gamma_deg * heat, "TSTC": t_c,
        "TSTO": t_c - 1.0 * gamma_deg * heat,
        "AMBTMP": AMBIENT_C + 0.3 * ar1_unit(rng, vx.size, 0.9999),
        "SR": sr, "SL": act["kappa"], "RUN": np.full(vx.size, float(run_number)),
    }
    fixed = {"P": 300.0, "RL": 5e-4, "RE": 5e-4, "TSTI": 0.2, "TSTC": 0.2, "TSTO": 0.2,
             "RST": 0.0, "AMBTMP": 0.0}
    for name in ("V", "N", "SA", "IA", "FX", "FY", "FZ", "MX", "MZ", "SL", "SR", *fixed):
        x = ch[name]
        level = noise if input_noise is None or name not in INPUT_CHANNELS else input_noise
        sigma = (fixed[name] * level / 0.01 if name in fixed
                 else level * float(np.sqrt(np.mean(x ** 2))))
        if name in SLIP_FLOOR:
            sigma = max(sigma, SLIP_FLOOR[name] * level / 0.01)
        if sigma > 0:
            ch[name] = x + sigma * ar1_unit(rng, x.size, ar1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ch["NFX"] = ch["FX"] / np.abs(ch["FZ"])
        ch["NFY"] = ch["FY"] / np.abs(ch["FZ"])
    return {name: ch[name] for name in TTC_CHANNELS}


def to_file_units(channels: dict[str, np.ndarray], units: str) -> tuple[dict, dict]:
    """SI (temperatures in degC) -> the file's units: ``"SI"`` (TTC's kph, cm, kPa, N-m,
    deg C) or ``"USCS"`` (mph, in, psi, lbf, ft-lb, deg F). Returns (channels, units)."""
    out, names = {}, {}
    for name, values in channels.items():
        spec = TTC_CHANNELS[name]
        unit = spec.si_unit if units == "SI" else spec.uscs_unit
        if spec.dimension == "temperature":
            kelvin = values + 273.15
            out[name] = (kelvin - to_si(0.0, unit, dimension="temperature")) / (
                to_si(1.0, unit, dimension="temperature") - to_si(0.0, unit,
                                                                  dimension="temperature"))
        elif spec.dimension == "angle":
            out[name] = np.rad2deg(values)
        else:
            out[name] = values / to_si(1.0, unit, dimension=spec.dimension)
        names[name] = unit
    return out, names
