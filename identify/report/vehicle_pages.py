"""The vehicle pages: what the tyre's pressures do to a car (``mfid vehicle``, and the fit
report when ``mfid fit --vehicle`` ran).

Four pages, built from a :class:`identify.vehicle.analysis.VehicleResult` alone (so from
vehicle.json): the handling diagrams of every setting on one plot with the axle cornering
stiffness against pressure; the table of figures with the validity notes; the yaw-rate and
lateral-acceleration frequency responses; the ride bars. Parts of a handling curve outside the
.tir's validity range are drawn dashed and a red line says which setting left it where.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from matplotlib import colormaps

from identify.report.layout import GREY, RED, Page, draw_table, new_page, text_block, wrap
from identify.vehicle.analysis import BAR, VehicleResult

__all__ = ["vehicle_pages", "fit_vehicle_pages", "VEHICLE_DIR"]

VEHICLE_DIR = "vehicle"
"""The fit directory's sub-folder that ``mfid fit --vehicle`` writes (vehicle.json, CSVs)."""


def _colours(n: int) -> list:
    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


def _footer(fig, res: VehicleResult) -> None:
    notes = res.tyre.get("notes") or ()
    if notes:
        what = "; ".join(n.split(":")[0].replace("the .tir's ", "") for n in notes)
        fig.text(0.04, 0.042, f"Default values, not identified, in the .tir: {what} (the "
                 "figures page says what follows)", fontsize=7, color=RED)
    tyre = Path(str(res.tyre.get("path", "tyre"))).name
    fig.text(0.04, 0.02, f"{tyre} on {res.spec.vehicle.name} - mfid {res.version}",
             fontsize=7, color=GREY)
    o = res.options
    fig.text(0.96, 0.02, f"transient at {o.speed_kmh:g} km/h; ride: ISO 8608 class "
             f"{o.road_class} at {o.road_speed_kmh:g} km/h, seed {o.seed}", fontsize=7,
             color=GREY, ha="right")


def _fmt(x: float, spec: str) -> str:
    return "-" if x is None or not math.isfinite(x) else format(x, spec)


def _handling_page(res: VehicleResult) -> Page:
    fig = new_page("Vehicle: steady-state cornering (ISO 4138, two-track)",
                   "Handling diagram: lateral acceleration against the difference of the axle "
                   "slip angles (negative: understeer); dashed where the .tir is extrapolated. "
                   "Right: axle cornering stiffness at the static wheel loads against pressure "
                   "(compliance steer included), the settings marked.")
    ax = fig.add_axes((0.07, 0.12, 0.50, 0.72))
    colours = _colours(len(res.settings))
    for s, c in zip(res.settings, colours):
        h = s.handling
        x = np.asarray(h["alpha_rear_minus_front_deg"], float)
        y = np.asarray(h["lateral_acceleration_mps2"], float)
        bad = np.asarray(h["outside_validity"], bool)
        good = ~bad
        # keep the valid part continuous up to the first flagged point, dash the rest
        ax.plot(np.where(good, x, np.nan), np.where(good, y, np.nan), color=c, lw=1.6,
                label=f"{s.label}: K {_fmt(s.figures['understeer_gradient_deg_per_mps2'], '.3f')}"
                      f", ay max {_fmt(s.figures['max_lateral_acceleration_mps2'], '.2f')}")
        if bad.any():
            first = max(int(np.argmax(bad)) - 1, 0)
            ax.plot(x[first:], y[first:], color=c, lw=1.2, ls="--")
        ax.plot(x[-1:], y[-1:], marker="o", ms=4, color=c)
    ax.axvline(0, color=GREY, lw=0.6)
    ax.set_xlabel("alpha_rear - alpha_front [deg]  (< 0: understeer)")
    ax.set_ylabel("lateral acceleration ay [m/s^2]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left", title="setting (front/rear): K [deg/(m/s^2)], "
                                                  "ay max [m/s^2]", title_fontsize=7)
    ax.set_ylim(bottom=0)
    # the change of the handling curve against the first setting
    cx = fig.add_axes((0.66, 0.55, 0.30, 0.29))
    base = res.settings[0].handling
    ay0 = np.asarray(base["lateral_acceleration_mps2"], float)
    x0 = np.asarray(base["alpha_rear_minus_front_deg"], float)
    for s, c in list(zip(res.settings, colours))[1:]:
        h = s.handling
        y = np.asarray(h["lateral_acceleration_mps2"], float)
        x = np.asarray(h["alpha_rear_minus_front_deg"], float)
        top = 0.95 * min(y.max(), ay0.max())
        grid = np.linspace(0.0, top, 60)
        cx.plot(grid, np.interp(grid, y, x) - np.interp(grid, ay0, x0), color=c)
    cx.axhline(0, color=colours[0], lw=1.0)
    cx.set_xlabel("lateral acceleration ay [m/s^2]", fontsize=8)
    cx.set_ylabel("change of alpha_r - alpha_f [deg]", fontsize=8)
    cx.set_title(f"against {res.settings[0].label}, up to 95 % of the lower ay max",
                 fontsize=8)
    cx.tick_params(labelsize=7)
    cx.grid(alpha=0.3)
    # stiffness against pressure
    bx = fig.add_axes((0.66, 0.12, 0.30, 0.29))
    sw = res.stiffness_vs_pressure
    p = np.asarray(sw["pressure_Pa"], float) / BAR
    bx.plot(p, np.asarray(sw["front_N_per_rad"], float) / 1e3, color="C0", label="front axle")
    bx.plot(p, np.asarray(sw["rear_N_per_rad"], float) / 1e3, color="C3", label="rear axle")
    for s in res.settings:
        f = s.figures
        bx.plot(f["front_pressure_Pa"] / BAR, f["axle_cornering_stiffness_front_N_per_rad"] / 1e3,
                "o", color="C0", ms=3.5)
        bx.plot(f["rear_pressure_Pa"] / BAR, f["axle_cornering_stiffness_rear_N_per_rad"] / 1e3,
                "s", color="C3", ms=3.5)
    vr = res.tyre.get("validity_range", {}).get("pressure_Pa")
    if vr and all(v is not None and math.isfinite(v) for v in vr):
        for v in vr:
            bx.axvline(v / BAR, color=GREY, lw=0.6, ls=":")
    bx.set_xlabel("inflation pressure [bar]  (dotted: the .tir's range)", fontsize=8)
    bx.set_ylabel("axle cornering stiffness\n[kN/rad]", fontsize=8)
    bx.tick_params(labelsize=7)
    bx.grid(alpha=0.3)
    bx.legend(fontsize=7)
    _footer(fig, res)
    return ("vehicle: handling", fig)


def _table_page(res: VehicleResult) -> Page:
    fig = new_page("Vehicle: figures per pressure setting",
                   "K: understeer gradient at vanishing lateral acceleration (road-wheel "
                   "angle); C: axle cornering stiffness at the static loads; yaw-rate gain r/delta"
                   " at the road wheel, natural frequency, damping and phase delay at 1 Hz of the"
                   " single-track model; ride: RMS over the four corners.")
    cols = ["setting [bar]", "K [deg/(m/s^2)]", "Cf [kN/rad]", "Cr [kN/rad]",
            "ay max [m/s^2]", "limit", "r/delta [1/s]", "fn [Hz]", "zeta",
            "lag 1 Hz [deg]", "acc RMS [m/s^2]", "Fz RMS [N]", "valid"]
    rows, colours = [], []
    for s in res.settings:
        f = s.figures
        rows.append([s.label.replace(" bar", ""),
                     _fmt(f["understeer_gradient_deg_per_mps2"], ".4f"),
                     _fmt(f["axle_cornering_stiffness_front_N_per_rad"] / 1e3, ".1f"),
                     _fmt(f["axle_cornering_stiffness_rear_N_per_rad"] / 1e3, ".1f"),
                     _fmt(f["max_lateral_acceleration_mps2"], ".2f"), s.limiting_axle,
                     _fmt(f["yaw_rate_gain_per_s"], ".3f"),
                     _fmt(f["yaw_natural_frequency_Hz"], ".3f"),
                     _fmt(f["yaw_damping_ratio"], ".3f"),
                     _fmt(f.get("yaw_phase_delay_1Hz_deg", math.nan), ".1f"),
                     _fmt(f["ride_body_acceleration_rms_mps2"], ".3f"),
                     _fmt(f["ride_wheel_load_rms_N"], ".0f"),
                     "no" if s.outside_validity else "yes"])
        colours.append(RED if s.outside_validity else "black")
    n = len(rows)
    row = 7.5 * 1.55 / 72 / 8.27  # one table row as a fraction of the page height
    h = min(0.40, row * (n + 2.5))
    ax = fig.add_axes((0.04, 0.86 - h, 0.92, h))
    widths = [0.08, 0.10, 0.08, 0.08, 0.095, 0.05, 0.085, 0.06, 0.05, 0.095, 0.10, 0.075,
              0.045]
    draw_table(ax, cols, rows, widths, fontsize=7.5, colours=colours,
               align=["left"] + ["right"] * 4 + ["left"] + ["right"] * 6 + ["left"])
    cols2 = ["setting [bar]", "K single track", "Cf eff. [kN/rad]", "Cr eff. [kN/rad]",
             "Cf tyres [kN/rad]", "Cr tyres [kN/rad]", "sigma f/r [m]", "ay lag 1 Hz [deg]",
             "Cz f/r [kN/m]"]
    rows2 = []
    for s in res.settings:
        f = s.figures
        g = f.get
        rows2.append([s.label.replace(" bar", ""),
                      _fmt(g("understeer_gradient_single_track_deg_per_mps2", math.nan), ".4f"),
                      _fmt(g("effective_axle_cornering_stiffness_front_N_per_rad", math.nan)
                           / 1e3, ".1f"),
                      _fmt(g("effective_axle_cornering_stiffness_rear_N_per_rad", math.nan)
                           / 1e3, ".1f"),
                      _fmt(g("tyre_cornering_stiffness_front_N_per_rad", math.nan) / 1e3, ".1f"),
                      _fmt(g("tyre_cornering_stiffness_rear_N_per_rad", math.nan) / 1e3, ".1f"),
                      f"{_fmt(g('relaxation_length_front_m', math.nan), '.3f')}/"
                      f"{_fmt(g('relaxation_length_rear_m', math.nan), '.3f')}",
                      _fmt(g("lateral_acceleration_phase_delay_1Hz_deg", math.nan), ".1f"),
                      f"{_fmt(g('vertical_stiffness_front_N_per_m', math.nan) / 1e3, '.0f')}/"
                      f"{_fmt(g('vertical_stiffness_rear_N_per_m', math.nan) / 1e3, '.0f')}"])
    h2 = min(0.30, row * (n + 2.5))
    ax2 = fig.add_axes((0.04, 0.83 - h - h2, 0.92, h2))
    draw_table(ax2, cols2, rows2, [0.09, 0.1, 0.11, 0.11, 0.11, 0.11, 0.1, 0.1, 0.1],
               fontsize=7.5, align=["left"] + ["right"] * 8)
    v = res.spec.vehicle
    left = wrap("K single track: ", "(m/l)(b/Cf - a/Cr) with the stiffnesses at the static "
                "loads; it differs from K where load transfer moves a force the tyres give at "
                "zero slip (ply steer, conicity, camber, toe). Cf/Cr eff.: the axle "
                "characteristics' slopes at vanishing ay, used by the frequency response. "
                "Cf/Cr tyres: without compliance steer.", 80)
    left += [""] + wrap("Vehicle: ", f"{v.name}; m {v.mass_kg:g} kg, l {v.wheelbase_m:g} m, "
                        f"a {v.a:g} m, h {v.cg_height_m:g} m, Iz {v.iz:g} kg m^2, roll "
                        f"stiffness front/rear {v.roll_stiffness_front_Nm_per_rad / 1e3:g}/"
                        f"{v.roll_stiffness_rear_Nm_per_rad / 1e3:g} kN m/rad, steering ratio "
                        f"{v.steering_ratio:g}; compliance steer front "
                        f"{v.steer_compliance_fy_front_deg_per_N * 1e3:g} deg/kN and "
                        f"{v.steer_compliance_mz_front_deg_per_Nm * 100:g} deg/(100 N m), rear "
                        f"{v.steer_compliance_fy_rear_deg_per_N * 1e3:g} deg/kN and "
                        f"{v.steer_compliance_mz_rear_deg_per_Nm * 100:g} deg/(100 N m); camber "
                        f"front/rear {v.static_camber_front_deg:g}/{v.static_camber_rear_deg:g}"
                        f" deg, toe {v.static_toe_front_deg:g}/{v.static_toe_rear_deg:g} deg.",
                        80)
    left += [""] + wrap("Model: ", "free-rolling tyres from the .tir at each axle's pressure "
                        "(right wheels mirrored), lateral load transfer m ay h split by roll "
                        "stiffness; the aligning moment acts through compliance steer only; no "
                        "drive force, roll steer or roll camber.", 80)
    top_text = 0.78 - h - h2
    text_block(fig.add_axes((0.04, 0.06, 0.45, top_text)), left, fontsize=7)
    lines = []
    base = res.settings[0]
    for s in res.settings[1:]:
        dk = (s.figures["understeer_gradient_deg_per_mps2"]
              - base.figures["understeer_gradient_deg_per_mps2"])
        da = (s.figures["ride_body_acceleration_rms_mps2"]
              / base.figures["ride_body_acceleration_rms_mps2"] - 1) * 100
        lines.append(f"{s.label} against {base.label}: K {dk:+.4f} deg/(m/s^2), "
                     f"body acc. RMS {da:+.1f} %")
    lines.append("")
    n_top = len(lines)
    text_block(fig.add_axes((0.52, 0.06, 0.45, top_text)), lines, fontsize=7)
    # each note once, with the settings it concerns
    grouped: dict[str, list[str]] = {}
    for n in res.tyre.get("notes") or ():
        grouped.setdefault(n, []).append("tyre")
    for st in res.settings:
        for n in st.validity_notes:
            grouped.setdefault(n, []).append(st.label.replace(" bar", ""))
    notes = ["Validity (.tir ranges: pressure, load, slip angle, camber; default keys):"]
    for n, who in grouped.items():
        head = ("every setting" if len(who) == len(res.settings) and who[0] != "tyre"
                else ", ".join(who))
        notes += wrap(f"  - {head}: ", n, 88)
    if len(grouped) == 0:
        notes.append("  every setting stays inside the .tir's ranges on its whole handling "
                     "curve")
    line_h = 7 * 1.45 / 72 / 8.27  # text_block's line height as a fraction of the page
    room = max(int(top_text / line_h) - n_top, 2)
    if len(notes) > room:
        notes = notes[:room - 1] + ["  ... more in vehicle.json (validity_notes)"]
    text_block(fig.add_axes((0.52, 0.06, 0.45, top_text - n_top * line_h)), notes,
               fontsize=7, colour=RED if grouped else "black")
    _footer(fig, res)
    return ("vehicle: figures", fig)


def _response_page(res: VehicleResult) -> Page:
    fig = new_page(f"Vehicle: frequency response (ISO 7401, linear, "
                   f"{res.options.speed_kmh:g} km/h)",
                   "Single-track model with the effective axle cornering stiffnesses of the "
                   "steady-state solve and the tyres' relaxation lengths at each pressure; input:"
                   " road-wheel steer angle.")
    colours = _colours(len(res.settings))
    axes = [fig.add_axes((0.07, 0.50, 0.40, 0.34)), fig.add_axes((0.56, 0.50, 0.40, 0.34)),
            fig.add_axes((0.07, 0.09, 0.40, 0.34)), fig.add_axes((0.56, 0.09, 0.40, 0.34))]
    for s, c in zip(res.settings, colours):
        r = s.response
        f = np.asarray(r["frequency_Hz"], float)
        axes[0].plot(f, r["yaw_rate_gain_per_s"], color=c, label=s.label)
        axes[1].plot(f, r["yaw_rate_phase_deg"], color=c)
        axes[2].plot(f, np.asarray(r["lateral_acceleration_gain_mps2_per_rad"], float)
                     * math.pi / 180, color=c)
        axes[3].plot(f, r["lateral_acceleration_phase_deg"], color=c)
    labels = ("yaw-rate gain r/delta [1/s]", "yaw-rate phase [deg]",
              "lateral-acceleration gain [(m/s^2)/deg]", "lateral-acceleration phase [deg]")
    for ax, lab in zip(axes, labels):
        ax.set_xscale("log")
        ax.set_ylabel(lab, fontsize=8)
        ax.set_xlabel("frequency [Hz]", fontsize=8)
        ax.axvline(1.0, color=GREY, lw=0.6, ls=":")
        ax.grid(alpha=0.3, which="both")
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=7)
    _footer(fig, res)
    return ("vehicle: frequency response", fig)


def _ride_page(res: VehicleResult) -> Page:
    o = res.options
    damping = res.tyre.get("vertical_damping_Ns_per_m", 0.0) or 0.0
    fig = new_page(f"Vehicle: ride (quarter car, ISO 8608 class {o.road_class}, "
                   f"{o.road_speed_kmh:g} km/h)",
                   f"Body acceleration and dynamic wheel load RMS of a front and a rear corner "
                   f"(the quarter car at that axle's pressure); tyre vertical stiffness from the "
                   f".tir at the corner's static load, tyre damping {damping:g} N s/m "
                   + ("(the .tir's)." if damping else "(the .tir gives none)."))
    labels = [s.label.replace(" bar", "") for s in res.settings]
    x = np.arange(len(labels))
    w = 0.38
    specs = (("body acceleration RMS [m/s^2]", "ride_body_acceleration_rms_front_mps2",
              "ride_body_acceleration_rms_rear_mps2"),
             ("dynamic wheel load RMS [N]", "ride_wheel_load_rms_front_N",
              "ride_wheel_load_rms_rear_N"),
             ("tyre vertical stiffness [kN/m]", "vertical_stiffness_front_N_per_m",
              "vertical_stiffness_rear_N_per_m"))
    for k, (lab, kf, kr) in enumerate(specs):
        ax = fig.add_axes((0.06 + 0.32 * k, 0.16, 0.26, 0.66))
        scale = 1e-3 if "stiffness" in lab else 1.0
        front = [s.figures.get(kf, math.nan) * scale for s in res.settings]
        rear = [s.figures.get(kr, math.nan) * scale for s in res.settings]
        ax.bar(x - w / 2, front, w, color="C0", label="front corner")
        ax.bar(x + w / 2, rear, w, color="C3", label="rear corner")
        lo = np.nanmin(front + rear)
        ax.set_ylim(0.9 * lo, 1.04 * np.nanmax(front + rear))
        ax.set_xticks(x, labels, rotation=45, fontsize=7, ha="right")
        ax.set_ylabel(lab, fontsize=8)
        ax.set_xlabel("setting front/rear [bar]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, axis="y")
        if k == 0:
            ax.legend(fontsize=7)
    q = res.spec.quarter_car
    fig.text(0.06, 0.05, f"Quarter car: body {q.sprung_mass_kg:g} kg, wheel "
             f"{q.unsprung_mass_kg:g} kg, spring {q.spring_N_per_m / 1e3:g} kN/m, damper "
             f"{q.damper_Ns_per_m:g} N s/m; point contact (no enveloping); the y axes do not "
             "start at 0.", fontsize=7.5)
    _footer(fig, res)
    return ("vehicle: ride", fig)


def vehicle_pages(res: VehicleResult) -> list[Page]:
    """The four vehicle pages of ``res`` (title, Figure)."""
    return [_handling_page(res), _table_page(res), _response_page(res), _ride_page(res)]


def fit_vehicle_pages(fd) -> list[Page]:
    """The vehicle pages of a fit directory whose ``vehicle/vehicle.json`` exists (written by
    ``mfid fit --vehicle``); none otherwise, or a page saying why it could not be read."""
    path = Path(fd.path) / VEHICLE_DIR / "vehicle.json"
    if not path.is_file():
        return []
    try:
        res = VehicleResult.from_dict(json.loads(path.read_text("utf-8")))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        fig = new_page("Vehicle", "")
        text_block(fig.add_axes((0.04, 0.1, 0.9, 0.75)),
                   [f"{path} could not be read: {exc}"], colour=RED)
        return [("vehicle", fig)]
    return vehicle_pages(res)
