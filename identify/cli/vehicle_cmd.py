"""``mfid vehicle``: what the tyre's pressures do to a car (docs/vehicle.md)."""
from __future__ import annotations

from pathlib import Path

import typer

from identify.cli.app import app, err_console, fail, out_console
from identify.core.errors import MfidError
from identify.vehicle.analysis import VehicleOptions
from identify.workflows.vehicle import OUTPUT_NAMES, analyse_vehicle

VEHICLE_HELP = ("Vehicle file (TOML, docs/vehicle.md); 'default' or absent: the bundled "
                "default sedan (rear-driven, 1660 kg, 50/50).")


@app.command("vehicle")
def vehicle_command(
    tir: Path = typer.Argument(..., help="Tyre property file (.tir) with pressure "
                                         "coefficients, e.g. a fit's."),
    vehicle: str = typer.Option("default", "--vehicle", metavar="FILE.toml", help=VEHICLE_HELP),
    pressures: list[str] = typer.Option(
        [], "--pressures", metavar="FRONT/REAR",
        help="A front/rear pressure setting in bar, e.g. 2.3/2.1; repeat for more. Default: "
             "2.5/2.5 1.9/1.9 2.2/2.2 3.0/3.0 2.7/2.5 2.5/2.2 2.7/2.2."),
    out: Path | None = typer.Option(None, "--out", metavar="DIR",
                                    help="Output folder (default vehicle/<tir name>)."),
    speed: float = typer.Option(100.0, "--speed", metavar="KMH",
                                help="Speed of the frequency response and yaw-rate gain "
                                     "[km/h]."),
    road_class: str = typer.Option("B", "--road-class", metavar="A-H",
                                   help="ISO 8608 road class of the ride."),
    road_speed: float = typer.Option(100.0, "--road-speed", metavar="KMH",
                                     help="Speed over the ride's road [km/h]."),
    seed: int = typer.Option(0, "--seed", help="Seed of the road profile's phases."),
    radius: float = typer.Option(100.0, "--radius", metavar="M",
                                 help="Circle radius of the steering-wheel angle column "
                                      "(ISO 4138 constant radius) [m]."),
    no_pdf: bool = typer.Option(False, "--no-pdf", help="Skip the PDF."),
) -> None:
    """Steady-state cornering (ISO 4138), linear frequency response (ISO 7401) and ride (ISO
    8608 road) of a vehicle on the tyre at front/rear pressure settings.

    Writes DIR/vehicle.json, settings.csv, handling_diagram.csv, frequency_response.csv,
    axle_stiffness_vs_pressure.csv and vehicle.pdf. Exit 2 on bad input.
    """
    folder = out if out is not None else Path("vehicle") / tir.stem
    options = VehicleOptions(speed_kmh=speed, road_class=road_class.upper(),
                             road_speed_kmh=road_speed, seed=seed, radius_m=radius)
    try:
        result = analyse_vehicle(tir, vehicle, pressures or None, out=folder, pdf=not no_pdf,
                                 options=options)
    except MfidError as exc:
        fail(exc)
    head = (f"{'setting [bar]':<14} {'K [deg/(m/s^2)]':>15} {'Cf [kN/rad]':>11} "
            f"{'Cr [kN/rad]':>11} {'ay max':>7} {'r/delta':>8} {'fn [Hz]':>7} {'zeta':>6} "
            f"{'acc RMS':>8} {'Fz RMS':>7}")
    out_console.print(f"{result.spec.vehicle.name} on {tir.name}", markup=False)
    out_console.print(head, markup=False, highlight=False)
    for s in result.settings:
        f = s.figures
        out_console.print(
            f"{s.label.replace(' bar', ''):<14} {f['understeer_gradient_deg_per_mps2']:>15.4f} "
            f"{f['axle_cornering_stiffness_front_N_per_rad'] / 1e3:>11.1f} "
            f"{f['axle_cornering_stiffness_rear_N_per_rad'] / 1e3:>11.1f} "
            f"{f['max_lateral_acceleration_mps2']:>7.2f} {f['yaw_rate_gain_per_s']:>8.3f} "
            f"{f['yaw_natural_frequency_Hz']:>7.3f} {f['yaw_damping_ratio']:>6.3f} "
            f"{f['ride_body_acceleration_rms_mps2']:>8.3f} {f['ride_wheel_load_rms_N']:>7.0f}",
            markup=False, highlight=False)
    for note in result.tyre.get("notes") or ():
        err_console.print(f"warning: {note}", markup=False, highlight=False)
    for s in result.settings:
        for note in s.validity_notes:
            err_console.print(f"warning: {s.label}: {note}", markup=False, highlight=False)
    out_console.print("outputs:", markup=False)
    for key, name in OUTPUT_NAMES.items():
        if key != "pdf" or not no_pdf:
            out_console.print(f"  {folder / name}", markup=False, highlight=False)
