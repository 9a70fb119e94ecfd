"""One call from a tyre and a vehicle to every figure of every pressure setting.

:func:`analyse` runs the steady-state circular test (two-track, :mod:`.steady`), the linear
frequency response (single track with relaxation lengths, :mod:`.transient`) and the ride
(quarter car on an ISO 8608 road, :mod:`.ride`) for each front/rear pressure pair and returns a
:class:`VehicleResult`, which is written to and read back from ``vehicle.json`` unchanged.
Every operating point outside the .tir's validity range (pressure, load, slip angle, camber)
is listed in the setting's ``validity_notes`` and marked on the handling curve.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from identify.core.errors import InputError
from identify.core.serial import Serial, meta
from identify.vehicle import steady
from identify.vehicle.ride import ROAD_CLASSES, QuarterCarModel, ride_response, road_profile
from identify.vehicle.spec import VehicleSpec
from identify.vehicle.transient import SingleTrack, frequency_response, phase_delay_deg
from identify.vehicle.tyre import AxleTyre, ValidityRange

__all__ = ["VehicleOptions", "SettingResult", "VehicleResult", "analyse", "parse_pressures",
           "DEFAULT_SETTINGS_BAR", "FIGURE_KEYS"]

DEFAULT_SETTINGS_BAR: tuple[tuple[float, float], ...] = (
    (2.5, 2.5), (1.9, 1.9), (2.2, 2.2), (3.0, 3.0), (2.7, 2.5), (2.5, 2.2), (2.7, 2.2))
"""Front/rear pressures [bar] when none are given: the nominal 2.5/2.5, all four tyres at the
low, middle and high pressures of the thesis's measurement grid (1.9-3.0 bar), the front
raised, the rear lowered, and both."""

FIGURE_KEYS = (
    "front_pressure_Pa", "rear_pressure_Pa", "understeer_gradient_deg_per_mps2",
    "axle_cornering_stiffness_front_N_per_rad", "axle_cornering_stiffness_rear_N_per_rad",
    "max_lateral_acceleration_mps2", "yaw_rate_gain_per_s", "yaw_natural_frequency_Hz",
    "yaw_damping_ratio", "ride_body_acceleration_rms_mps2", "ride_wheel_load_rms_N")
"""The figures every setting carries (vehicle.json, settings.csv), in this order; more follow
(:data:`EXTRA_KEYS`)."""
EXTRA_KEYS = (
    "understeer_gradient_single_track_deg_per_mps2",
    "effective_axle_cornering_stiffness_front_N_per_rad",
    "effective_axle_cornering_stiffness_rear_N_per_rad",
    "tyre_cornering_stiffness_front_N_per_rad", "tyre_cornering_stiffness_rear_N_per_rad",
    "relaxation_length_front_m", "relaxation_length_rear_m",
    "yaw_phase_delay_1Hz_deg", "lateral_acceleration_phase_delay_1Hz_deg",
    "lateral_acceleration_gain_mps2_per_deg",
    "vertical_stiffness_front_N_per_m", "vertical_stiffness_rear_N_per_m",
    "ride_body_acceleration_rms_front_mps2", "ride_body_acceleration_rms_rear_mps2",
    "ride_wheel_load_rms_front_N", "ride_wheel_load_rms_rear_N")
BAR = 1e5


def parse_pressures(text: str) -> tuple[float, float]:
    """``"FRONT/REAR"`` in bar (``"2.3/2.1"``) -> (front, rear) [Pa]; InputError otherwise."""
    parts = str(text).split("/")
    try:
        if len(parts) != 2:
            raise ValueError
        front, rear = (float(x) for x in parts)
    except ValueError:
        raise InputError(None, f"{text!r} is not FRONT/REAR in bar (e.g. 2.3/2.1)",
                         key="--pressures") from None
    for value in (front, rear):
        if not (math.isfinite(value) and 0.5 <= value <= 10.0):
            raise InputError(None, f"{text!r}: {value:g} bar is not a tyre pressure (0.5-10 "
                                   "bar gauge)", key="--pressures")
    # to the millipascal: 2.3 bar is 230000 Pa, not 229999.99999999997
    return round(front * BAR, 3), round(rear * BAR, 3)


@dataclass(frozen=True)
class VehicleOptions:
    """How the manoeuvres are run.

    Attributes
    ----------
    speed_kmh : float [km/h]        speed of the frequency response and the yaw-rate gain
    road_class : str                ISO 8608 class A-H of the ride's road
    road_speed_kmh : float [km/h]   speed over that road
    seed : int                      phases of the road profile
    radius_m : float [m]            circle radius of the steering-wheel angle (ISO 4138)
    curve_points : int              points of each handling curve
    """

    speed_kmh: float = 100.0
    road_class: str = "B"
    road_speed_kmh: float = 100.0
    seed: int = 0
    radius_m: float = 100.0
    curve_points: int = 41

    def check(self) -> None:
        """InputError naming the option that no test could use."""
        if self.road_class not in ROAD_CLASSES:
            raise InputError(None, f"{self.road_class!r} is not an ISO 8608 road class (A-H)",
                             key="--road-class")
        for key, value, lo, hi in (("--speed", self.speed_kmh, 1.0, 400.0),
                                   ("--road-speed", self.road_speed_kmh, 1.0, 400.0),
                                   ("--radius", self.radius_m, 5.0, 10000.0)):
            if not (math.isfinite(value) and lo <= value <= hi):
                raise InputError(None, f"{value:g} is outside {lo:g}-{hi:g}", key=key)
        if self.seed < 0:
            raise InputError(None, f"seed must be >= 0, not {self.seed}", key="--seed")


@dataclass(frozen=True)
class SettingResult:
    """Everything computed for one front/rear pressure pair.

    Attributes
    ----------
    label : str                          "2.5/2.2 bar"
    figures : mapping                    FIGURE_KEYS and EXTRA_KEYS -> float
    limiting_axle : str                  the axle that saturates first ("front", "rear")
    stable : bool                        every eigenvalue of the single-track model < 0
    handling : mapping                   the handling curve, column -> tuple
    response : mapping                   the frequency responses, column -> tuple
    validity_notes : tuple of str        every way the setting leaves the .tir's range
    """

    label: str
    figures: Mapping[str, float]
    limiting_axle: str
    stable: bool
    handling: Mapping[str, tuple]
    response: Mapping[str, tuple]
    validity_notes: tuple[str, ...] = ()

    @property
    def outside_validity(self) -> bool:
        return bool(self.validity_notes)

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, **dict(self.figures),
                "limiting_axle": self.limiting_axle, "stable": self.stable,
                "outside_validity": self.outside_validity,
                "validity_notes": list(self.validity_notes),
                "handling_diagram": {k: list(v) for k, v in self.handling.items()},
                "frequency_response": {k: list(v) for k, v in self.response.items()}}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SettingResult:
        figures = {k: (math.nan if d.get(k) is None else float(d[k]))
                   for k in FIGURE_KEYS + EXTRA_KEYS if k in d}
        return cls(d["label"], figures, d["limiting_axle"], bool(d["stable"]),
                   {k: tuple(v) for k, v in d["handling_diagram"].items()},
                   {k: tuple(v) for k, v in d["frequency_response"].items()},
                   tuple(d.get("validity_notes", ())))


@dataclass(frozen=True)
class VehicleResult(Serial):
    """The analysis of one tyre on one vehicle at several pressure settings.

    Attributes
    ----------
    tyre : mapping             path, sha256, fittyp, validity_range, vertical damping used
    spec : VehicleSpec
    options : VehicleOptions
    settings : tuple of SettingResult
    stiffness_vs_pressure : mapping   pressure_Pa, front_N_per_rad, rear_N_per_rad (axle
                                      cornering stiffness at the static loads) -> tuple
    version : str              mfid version
    """

    tyre: Mapping[str, Any]
    spec: VehicleSpec = field(metadata=meta(key="vehicle"))
    options: VehicleOptions
    settings: tuple[SettingResult, ...]
    stiffness_vs_pressure: Mapping[str, tuple] = field(
        metadata=meta(key="axle_cornering_stiffness_vs_pressure"))
    version: str = field(default="", metadata=meta(key="mfid_version"))

    serial_order = ("mfid_version",)  # vehicle.json's order: then the fields


def _outside(value: float, rng: tuple[float, float]) -> bool:
    return bool(value < rng[0] or value > rng[1])


def _range_text(rng: tuple[float, float], scale: float, unit: str, fmt: str = "g") -> str:
    return f"{rng[0] / scale:{fmt}}-{rng[1] / scale:{fmt}} {unit}"


def _validity(vr: ValidityRange, spec: VehicleSpec, pf: float, pr: float, ay: np.ndarray,
              front: steady.AxleSolution, rear: steady.AxleSolution
              ) -> tuple[list[str], np.ndarray]:
    """Notes for one setting and a per-curve-point flag."""
    notes = []
    for axle, p in (("front", pf), ("rear", pr)):
        if _outside(p, vr.pressure_Pa):
            notes.append(f"{axle} pressure {p / BAR:.2f} bar is outside the .tir's "
                         f"{_range_text(vr.pressure_Pa, BAR, 'bar', '.2f')}: extrapolated")
    v = spec.vehicle
    for axle, cam in (("front", v.static_camber_front_deg), ("rear", v.static_camber_rear_deg)):
        if _outside(-math.radians(cam), vr.camber_rad):
            notes.append(f"{axle} camber {cam:g} deg is outside the .tir's camber range")
    qload = spec.quarter_car.static_load
    if _outside(qload, vr.load_N):
        notes.append(f"quarter-car wheel load {qload:.0f} N is outside the .tir's "
                     f"{_range_text(vr.load_N, 1, 'N', '.0f')}: ride extrapolated")
    flag = np.zeros(ay.shape, bool)
    for name, sol in (("front", front), ("rear", rear)):
        loads = np.stack([sol.fz_left, sol.fz_right])
        bad_load = (loads < vr.load_N[0]) | (loads > vr.load_N[1])
        slips = np.stack([sol.alpha_left, sol.alpha_right])
        bad_slip = (slips < vr.slip_angle_rad[0]) | (slips > vr.slip_angle_rad[1])
        for what, bad, rng, unit, scale, fmt in (
                ("wheel loads", bad_load, vr.load_N, "N", 1.0, ".0f"),
                ("wheel slip angles", bad_slip, vr.slip_angle_rad, "deg", math.pi / 180,
                 ".1f")):
            point = bad.any(axis=0)
            flag |= point
            if point.any():
                first = float(ay[point].min())
                notes.append(f"{name} {what} leave the .tir's "
                             f"{_range_text(rng, scale, unit, fmt)} from ay = {first:.2f} "
                             "m/s^2 on: that part of the handling curve is extrapolated")
    if _outside(v.static_wheel_load("front"), vr.load_N) or _outside(
            v.static_wheel_load("rear"), vr.load_N):
        notes.append("static wheel loads are outside the .tir's load range: every handling "
                     "figure is extrapolated")
        flag[:] = True
    return notes, flag


def analyse(tyre: AxleTyre, spec: VehicleSpec,
            pressures_Pa: Sequence[tuple[float, float]],
            options: VehicleOptions = VehicleOptions(), *,
            tyre_info: Mapping[str, Any] | None = None, version: str = "") -> VehicleResult:
    """Handling and ride figures of ``spec``'s vehicle on ``tyre`` at each front/rear
    pressure pair [Pa].

    Parameters
    ----------
    tyre : AxleTyre            e.g. ``MfTyre(read_tir(path).params())``
    spec : VehicleSpec         ``read_vehicle(path)`` or ``default_vehicle()``
    pressures_Pa : sequence of (front, rear) [Pa]
    options : VehicleOptions
    tyre_info : mapping, optional    recorded as the result's ``tyre`` (path, checksum ...)
    version : str                    recorded as the result's mfid version
    """
    options.check()
    v, qc = spec.vehicle, spec.quarter_car
    pf = np.array([p[0] for p in pressures_Pa], float)
    pr = np.array([p[1] for p in pressures_Pa], float)
    if pf.size == 0:
        raise InputError(None, "no pressure setting given", key="--pressures")
    vr = tyre.validity
    front_ax, rear_ax = steady.axle_setups(v)
    fz_f, fz_r = v.static_wheel_load("front"), v.static_wheel_load("rear")
    deg = 180 / math.pi

    # steady state: stiffnesses at the static loads, understeer gradient, limit, curves
    c_f = steady.axle_cornering_stiffness(tyre, front_ax, fz_f, pf)
    c_r = steady.axle_cornering_stiffness(tyre, rear_ax, fz_r, pr)
    t_f = steady.axle_cornering_stiffness(tyre, front_ax.rigid(), fz_f, pf)
    t_r = steady.axle_cornering_stiffness(tyre, rear_ax.rigid(), fz_r, pr)
    if not (np.all(t_f > 0) and np.all(t_r > 0)):
        raise InputError((tyre_info or {}).get("path"), "the tyre's cornering stiffness at the "
                         "vehicle's static wheel loads is not positive in ISO-W signs (a "
                         "positive slip angle must give a negative Fy): no car can corner on it")
    eps_ay = 0.01
    f0, r0 = steady.handling_points(tyre, v, eps_ay, pf, pr)
    k_two_track = (f0.alpha - r0.alpha) / eps_ay
    m, a, b, wb = v.mass_kg, v.a, v.b, v.wheelbase_m
    ce_f = m * eps_ay * b / wb / f0.alpha
    ce_r = m * eps_ay * a / wb / r0.alpha
    k_single = m / wb * (b / c_f - a / c_r)
    ay_max, limiting = steady.max_lateral_acceleration(tyre, v, pf, pr)
    n = options.curve_points
    s = np.concatenate([np.linspace(0.0, 0.98, n - 2), [0.99, 0.998]])
    top = np.where(np.isfinite(ay_max), ay_max, 3.0 * 9.81)
    ay = top[:, None] * s[None, :]
    front, rear = steady.handling_points(tyre, v, ay, pf[:, None], pr[:, None])

    # transient
    sig_f = tyre.relaxation_length(fz_f, -math.radians(v.static_camber_front_deg), pf)
    sig_r = tyre.relaxation_length(fz_r, -math.radians(v.static_camber_rear_deg), pr)
    V = options.speed_kmh / 3.6

    # ride: one corner at each axle's pressure
    road = road_profile(options.road_class, options.seed)
    vr_speed = options.road_speed_kmh / 3.6
    cz_f, damping = tyre.vertical(qc.static_load, pf, vr_speed)
    cz_r, _ = tyre.vertical(qc.static_load, pr, vr_speed)

    results = []
    for i in range(pf.size):
        model = SingleTrack(m, v.iz, a, b, float(ce_f[i]), float(ce_r[i]), float(sig_f[i]),
                            float(sig_r[i]), V)
        fn, zeta, stable = model.body_mode()
        yaw_delay, ay_delay = phase_delay_deg(model)
        fr = frequency_response(model)
        rides = [ride_response(QuarterCarModel(qc.sprung_mass_kg, qc.unsprung_mass_kg,
                                               qc.spring_N_per_m, qc.damper_Ns_per_m,
                                               float(cz[i]), damping), road, vr_speed)
                 for cz in (cz_f, cz_r)]
        ay_gain = abs(model.response([0.0])[1][0]) / deg
        figures = {
            "front_pressure_Pa": pf[i], "rear_pressure_Pa": pr[i],
            "understeer_gradient_deg_per_mps2": k_two_track[i] * deg,
            "axle_cornering_stiffness_front_N_per_rad": c_f[i],
            "axle_cornering_stiffness_rear_N_per_rad": c_r[i],
            "max_lateral_acceleration_mps2": ay_max[i],
            "yaw_rate_gain_per_s": model.steady_state_yaw_gain(),
            "yaw_natural_frequency_Hz": fn, "yaw_damping_ratio": zeta,
            "ride_body_acceleration_rms_mps2": math.sqrt(
                (rides[0].body_acceleration_rms ** 2 + rides[1].body_acceleration_rms ** 2) / 2),
            "ride_wheel_load_rms_N": math.sqrt(
                (rides[0].wheel_load_rms ** 2 + rides[1].wheel_load_rms ** 2) / 2),
            "understeer_gradient_single_track_deg_per_mps2": k_single[i] * deg,
            "effective_axle_cornering_stiffness_front_N_per_rad": ce_f[i],
            "effective_axle_cornering_stiffness_rear_N_per_rad": ce_r[i],
            "tyre_cornering_stiffness_front_N_per_rad": t_f[i],
            "tyre_cornering_stiffness_rear_N_per_rad": t_r[i],
            "relaxation_length_front_m": sig_f[i], "relaxation_length_rear_m": sig_r[i],
            "yaw_phase_delay_1Hz_deg": yaw_delay,
            "lateral_acceleration_phase_delay_1Hz_deg": ay_delay,
            "lateral_acceleration_gain_mps2_per_deg": ay_gain,
            "vertical_stiffness_front_N_per_m": cz_f[i], "vertical_stiffness_rear_N_per_m": cz_r[i],
            "ride_body_acceleration_rms_front_mps2": rides[0].body_acceleration_rms,
            "ride_body_acceleration_rms_rear_mps2": rides[1].body_acceleration_rms,
            "ride_wheel_load_rms_front_N": rides[0].wheel_load_rms,
            "ride_wheel_load_rms_rear_N": rides[1].wheel_load_rms,
        }
        fi = _row(front, i, ay.shape)
        ri = _row(rear, i, ay.shape)
        notes, flag = _validity(vr, spec, pf[i], pr[i], ay[i], fi, ri)
        if not stable:
            notes.append("the single-track model is unstable at this speed: the frequency "
                         "response is not that of a drivable car")
        d_alpha = (fi.alpha - ri.alpha)
        handling = {
            "lateral_acceleration_mps2": tuple(ay[i]),
            "alpha_front_deg": tuple(fi.alpha * deg), "alpha_rear_deg": tuple(ri.alpha * deg),
            "alpha_rear_minus_front_deg": tuple(-d_alpha * deg),
            "steering_wheel_angle_deg": tuple(v.steering_ratio * (wb / options.radius_m
                                                                  + d_alpha) * deg),
            "fz_front_inner_N": tuple(fi.fz_left), "fz_front_outer_N": tuple(fi.fz_right),
            "fz_rear_inner_N": tuple(ri.fz_left), "fz_rear_outer_N": tuple(ri.fz_right),
            "outside_validity": tuple(bool(x) for x in flag)}
        response = {"frequency_Hz": tuple(fr.f_hz), "yaw_rate_gain_per_s": tuple(fr.yaw_gain),
                    "yaw_rate_phase_deg": tuple(fr.yaw_phase_deg),
                    "lateral_acceleration_gain_mps2_per_rad": tuple(fr.ay_gain),
                    "lateral_acceleration_phase_deg": tuple(fr.ay_phase_deg)}
        label = f"{pf[i] / BAR:.2f}/{pr[i] / BAR:.2f} bar"
        results.append(SettingResult(label, {k: float(x) for k, x in figures.items()},
                                     str(limiting[i]), stable, handling, response,
                                     tuple(notes)))

    # axle cornering stiffness against pressure, over the .tir's range and the settings
    lo = min(vr.pressure_Pa[0] if math.isfinite(vr.pressure_Pa[0]) else 1.5 * BAR,
             float(min(pf.min(), pr.min())))
    hi = max(vr.pressure_Pa[1] if math.isfinite(vr.pressure_Pa[1]) else 3.5 * BAR,
             float(max(pf.max(), pr.max())))
    sweep = np.linspace(lo, hi, 21)
    stiff = {"pressure_Pa": tuple(sweep),
             "front_N_per_rad": tuple(steady.axle_cornering_stiffness(tyre, front_ax, fz_f,
                                                                      sweep)),
             "rear_N_per_rad": tuple(steady.axle_cornering_stiffness(tyre, rear_ax, fz_r,
                                                                     sweep))}
    info = dict(tyre_info or {})
    info.setdefault("validity_range", vr.to_dict())
    info.setdefault("vertical_damping_Ns_per_m", damping)
    return VehicleResult(info, spec, options, tuple(results), stiff, version)


def _row(sol: steady.AxleSolution, i: int, shape) -> steady.AxleSolution:
    """Row ``i`` of a flattened (settings x points) solution."""
    def r(x):
        return np.asarray(x).reshape(shape)[i]
    return steady.AxleSolution(r(sol.alpha), r(sol.force), r(sol.alpha_left),
                               r(sol.alpha_right), r(sol.fz_left), r(sol.fz_right), r(sol.mz))
