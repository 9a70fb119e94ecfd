"""The vehicle: a frozen description read from a TOML file (or the bundled default sedan).

The file has two tables, ``[vehicle]`` and ``[quarter_car]``, SI keys whose names carry their
unit (angles in degrees where the name says ``_deg``). docs/vehicle.md lists every key; the
default is ``default_sedan.toml`` beside this module. Unknown tables or keys, missing keys,
values that are not numbers and values no car has are :class:`InputError` (one line naming the
file and key).
"""
from __future__ import annotations

import hashlib
import math
import tomllib
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, fields
from importlib.resources import files
from pathlib import Path
from typing import Any

from identify.core.errors import InputError
from identify.core.serial import Serial

__all__ = ["Vehicle", "QuarterCar", "VehicleSpec", "read_vehicle", "default_vehicle",
           "DEFAULT_VEHICLE_FILE", "G"]

G = 9.81
"""Gravitational acceleration [m/s^2]."""

DEFAULT_VEHICLE_FILE = "default_sedan.toml"


@dataclass(frozen=True)
class Vehicle:
    """Rigid-body and suspension data of the two-track and single-track models.

    Attributes
    ----------
    mass_kg : float [kg]
    wheelbase_m : float [m]                    l
    cg_to_front_axle_m : float [m]             a (b = l - a)
    cg_height_m : float [m]                    h, above the ground (0: no load transfer)
    track_front_m, track_rear_m : float [m]
    roll_stiffness_front_Nm_per_rad, roll_stiffness_rear_Nm_per_rad : float [N m/rad]
        They split the roll moment m ay h between the axles.
    steering_ratio : float [-]                 steering-wheel angle / road-wheel angle
    yaw_inertia_kgm2 : float [kg m^2]          NaN in the file's absence: m a b
    static_camber_front_deg, static_camber_rear_deg : float [deg]
        Negative: top of the wheel leaning towards the car.
    static_toe_front_deg, static_toe_rear_deg : float [deg]   per wheel, positive toe-in
    steer_compliance_fy_front_deg_per_N, ..._rear_... : float [deg/N]
        Steer of a wheel per newton of its own lateral force, positive when the wheel steers
        the way the force pushes it (its slip angle falls).
    steer_compliance_mz_front_deg_per_Nm, ..._rear_... : float [deg/(N m)]
        Steer of a wheel per N m of its own aligning moment, positive when the wheel steers the
        way the moment turns it (its slip angle falls).
    name : str
    """

    mass_kg: float
    wheelbase_m: float
    cg_to_front_axle_m: float
    cg_height_m: float
    track_front_m: float
    track_rear_m: float
    roll_stiffness_front_Nm_per_rad: float
    roll_stiffness_rear_Nm_per_rad: float
    steering_ratio: float = 16.0
    yaw_inertia_kgm2: float = math.nan
    static_camber_front_deg: float = 0.0
    static_camber_rear_deg: float = 0.0
    static_toe_front_deg: float = 0.0
    static_toe_rear_deg: float = 0.0
    steer_compliance_fy_front_deg_per_N: float = 0.0
    steer_compliance_fy_rear_deg_per_N: float = 0.0
    steer_compliance_mz_front_deg_per_Nm: float = 0.0
    steer_compliance_mz_rear_deg_per_Nm: float = 0.0
    name: str = "vehicle"

    @property
    def a(self) -> float:
        """Centre of gravity to front axle [m]."""
        return self.cg_to_front_axle_m

    @property
    def b(self) -> float:
        """Centre of gravity to rear axle [m]."""
        return self.wheelbase_m - self.cg_to_front_axle_m

    @property
    def iz(self) -> float:
        """Yaw moment of inertia [kg m^2]: the file's, else m a b (dynamic index 1)."""
        if math.isfinite(self.yaw_inertia_kgm2):
            return self.yaw_inertia_kgm2
        return self.mass_kg * self.a * self.b

    def static_wheel_load(self, axle: str) -> float:
        """Static load of one wheel of ``axle`` ("front" or "rear") [N]."""
        share = self.b if axle == "front" else self.a
        return self.mass_kg * G * share / self.wheelbase_m / 2.0

    def load_transfer_per_ay(self, axle: str) -> float:
        """Lateral load transfer of ``axle`` per unit lateral acceleration [N/(m/s^2)]:
        the roll moment m h split by roll stiffness, over the axle's track."""
        kf, kr = self.roll_stiffness_front_Nm_per_rad, self.roll_stiffness_rear_Nm_per_rad
        share = (kf if axle == "front" else kr) / (kf + kr) if kf + kr > 0 else 0.5
        track = self.track_front_m if axle == "front" else self.track_rear_m
        return self.mass_kg * self.cg_height_m * share / track


@dataclass(frozen=True)
class QuarterCar:
    """One corner for the ride: body and wheel masses, suspension spring and damper.

    Attributes
    ----------
    sprung_mass_kg, unsprung_mass_kg : float [kg]
    spring_N_per_m : float [N/m]         wheel rate
    damper_Ns_per_m : float [N s/m]      at the wheel
    """

    sprung_mass_kg: float
    unsprung_mass_kg: float
    spring_N_per_m: float
    damper_Ns_per_m: float

    @property
    def static_load(self) -> float:
        """The corner's static wheel load [N]."""
        return (self.sprung_mass_kg + self.unsprung_mass_kg) * G


@dataclass(frozen=True)
class VehicleSpec(Serial):
    """A vehicle file, read: the vehicle, its quarter car, where it came from.

    Attributes
    ----------
    vehicle : Vehicle
    quarter_car : QuarterCar
    source : str          the file, or "default sedan (identify/vehicle/default_sedan.toml)"
    sha256 : str          of the file's bytes
    """

    vehicle: Vehicle
    quarter_car: QuarterCar
    source: str
    sha256: str

    serial_order = ("source", "sha256")  # vehicle.json's order: then the vehicle, the corner


# (lower, upper, lower inclusive) of every number; the bounds reject what no road car has
_BOUNDS: dict[str, tuple[float, float, bool]] = {
    "mass_kg": (0.0, 60000.0, False),
    "wheelbase_m": (0.0, 20.0, False),
    "cg_to_front_axle_m": (0.0, 20.0, False),
    "cg_height_m": (0.0, 5.0, True),
    "track_front_m": (0.0, 5.0, False),
    "track_rear_m": (0.0, 5.0, False),
    "roll_stiffness_front_Nm_per_rad": (0.0, 1e8, True),
    "roll_stiffness_rear_Nm_per_rad": (0.0, 1e8, True),
    "steering_ratio": (0.0, 100.0, False),
    "yaw_inertia_kgm2": (0.0, 1e7, False),
    "static_camber_front_deg": (-10.0, 10.0, True),
    "static_camber_rear_deg": (-10.0, 10.0, True),
    "static_toe_front_deg": (-5.0, 5.0, True),
    "static_toe_rear_deg": (-5.0, 5.0, True),
    "steer_compliance_fy_front_deg_per_N": (-0.01, 0.01, True),
    "steer_compliance_fy_rear_deg_per_N": (-0.01, 0.01, True),
    "steer_compliance_mz_front_deg_per_Nm": (-0.5, 0.5, True),
    "steer_compliance_mz_rear_deg_per_Nm": (-0.5, 0.5, True),
    "sprung_mass_kg": (0.0, 20000.0, False),
    "unsprung_mass_kg": (0.0, 2000.0, False),
    "spring_N_per_m": (0.0, 1e7, False),
    "damper_Ns_per_m": (0.0, 1e6, True),
}


def _numbers(path: str, table: str, raw: Mapping[str, Any], cls) -> dict[str, Any]:
    known = {f.name: f for f in fields(cls)}
    out: dict[str, Any] = {}
    for key, value in raw.items():
        where = f"{table}.{key}"
        if key not in known:
            raise InputError(path, f"unknown key (the keys of [{table}] are listed in "
                                   "docs/vehicle.md)", key=where)
        if key == "name":
            if not isinstance(value, str):
                raise InputError(path, "name must be a string", key=where)
            out[key] = value
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(path, f"must be a number, not {value!r}", key=where)
        value = float(value)
        lo, hi, inclusive = _BOUNDS[key]
        if not math.isfinite(value) or value > hi or value < lo or (value == lo
                                                                    and not inclusive):
            bound = f"{'>=' if inclusive else '>'} {lo:g} and <= {hi:g}"
            raise InputError(path, f"impossible value {value:g} (must be {bound})", key=where)
        out[key] = value
    missing = [f.name for f in known.values() if f.default is MISSING and f.name not in out]
    if missing:
        raise InputError(path, f"missing key(s): {', '.join(missing)}", key=table)
    return out


def parse_vehicle(text: str, path: str) -> tuple[Vehicle, QuarterCar]:
    """The vehicle and quarter car of a vehicle file's text; InputError on any problem."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(path, f"not valid TOML: {exc}") from None
    for table in doc:
        if table not in ("vehicle", "quarter_car"):
            raise InputError(path, "unknown table (a vehicle file has [vehicle] and "
                                   "[quarter_car])", key=table)
    for table in ("vehicle", "quarter_car"):
        if not isinstance(doc.get(table), dict):
            raise InputError(path, "missing table", key=f"[{table}]")
    v = _numbers(path, "vehicle", doc["vehicle"], Vehicle)
    q = _numbers(path, "quarter_car", doc["quarter_car"], QuarterCar)
    vehicle = Vehicle(**v)
    if not vehicle.cg_to_front_axle_m < vehicle.wheelbase_m:
        raise InputError(path, f"impossible value {vehicle.cg_to_front_axle_m:g}: the centre "
                               f"of gravity must lie between the axles (wheelbase "
                               f"{vehicle.wheelbase_m:g} m)", key="vehicle.cg_to_front_axle_m")
    if vehicle.cg_height_m > 0 and (vehicle.roll_stiffness_front_Nm_per_rad
                                    + vehicle.roll_stiffness_rear_Nm_per_rad) <= 0:
        raise InputError(path, "both roll stiffnesses are 0: the roll moment of a centre of "
                               "gravity above the ground has nowhere to go",
                         key="vehicle.roll_stiffness_front_Nm_per_rad")
    return vehicle, QuarterCar(**q)


def read_vehicle(path: str | Path) -> VehicleSpec:
    """Read a vehicle file (TOML); ``"default"`` reads the bundled default sedan.

    Raises
    ------
    InputError
        Unreadable file, invalid TOML, unknown table or key, missing key, a value that is not
        a number or is impossible.
    """
    if str(path) == "default":
        return default_vehicle()
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(p, f"cannot read vehicle file: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(p, "not a UTF-8 text file") from None
    vehicle, qc = parse_vehicle(text, str(p))
    return VehicleSpec(vehicle, qc, str(p), hashlib.sha256(data).hexdigest())


def default_vehicle_text() -> str:
    """The bundled default vehicle file's text."""
    return files("identify.vehicle").joinpath(DEFAULT_VEHICLE_FILE).read_text("utf-8")


def default_vehicle() -> VehicleSpec:
    """The bundled default sedan (``identify/vehicle/default_sedan.toml``)."""
    text = default_vehicle_text()
    vehicle, qc = parse_vehicle(text, DEFAULT_VEHICLE_FILE)
    return VehicleSpec(vehicle, qc, f"default sedan (identify/vehicle/{DEFAULT_VEHICLE_FILE})",
                       hashlib.sha256(text.encode("utf-8")).hexdigest())
