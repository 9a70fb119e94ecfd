"""Test grids of the simulator: which runs are made and how densely they are sampled."""
from __future__ import annotations

from dataclasses import dataclass

from identify.core.serial import Serial

__all__ = ["Samples", "Grid", "FULL", "SMALL", "GRIDS"]


@dataclass(frozen=True)
class Samples(Serial):
    """Samples per run (Flatplank) or per sweep (trailer).

    ``vertical`` counts loading plus unloading; ``rolling`` is the rolling part of relaxation
    runs (a few standing samples come first); trailer counts are per load.

    The Flatplank counts are what a data acquisition of a few tens of Hz records at the rig's
    speeds (rig.py): a locked-hub run (2 mm/s over 2.5 saturation displacements, 20-40 s) at
    ~50 Hz, a camber run (4.75 cm/s over 7 relaxation lengths, 40-60 s) at ~25 Hz, a vertical
    run (1 mm/s down to the 9 kN deflection and back, 64-88 s for the default tyre) at
    23-31 Hz. The
    per-sample noise of the default artefacts (1 % of each bridge's RMS, amplified by the hub's
    lever arms) then averages down to the accuracy the extraction is specified for: the linear
    window of a stiffness run keeps ~350 samples (slope standard error ~0.25 % per cell), the
    steady camber moment Mx at 2 deg (~20 N m against ~4 N m of noise per sample) ~0.5 % per
    cell, and CFz 0.07-0.15 % per cell (at the 3-5 Hz of 300 samples per vertical run up to
    0.36 %, and the worst of 15 cells passed 1 % in 3 % of the seeds).
    """

    vertical: int = 2000
    stiffness: int = 1500
    parking: int = 500
    rolling: int = 150
    free_rolling: int = 40
    camber: int = 1200
    lead_in: int = 8
    trailer_alpha: int = 193
    trailer_kappa: int = 193
    trailer_combined: int = 161
    trailer_camber: int = 129
    trailer_rr: int = 20


@dataclass(frozen=True)
class Grid(Serial):
    """Pressures, loads, angles and sample counts of one simulated folder.

    Pressures in [bar], loads in [N], angles in [deg], speeds in [m/s].
    """

    name: str
    pressures_bar: tuple[float, ...] = (1.9, 2.2, 2.5, 2.7, 3.0)
    loads: tuple[float, ...] = (3000.0, 5000.0, 7000.0)
    long_loads: tuple[float, ...] = (2000.0, 4000.0, 6000.0)
    parking_loads: tuple[float, ...] = (1000.0, 2000.0, 3000.0, 4000.0, 5000.0, 6000.0)
    starts: int = 3
    camber_deg: tuple[float, ...] = (-15.0, -10.0, -5.0, -2.0, 0.0, 2.0, 5.0, 10.0, 15.0)
    relaxation_deg: float = 1.0
    trailer_pressures_bar: tuple[float, ...] = (1.9, 2.5, 3.0)
    trailer_loads: tuple[float, ...] = (3000.0, 5000.0, 7000.0)
    trailer_speed: float = 16.7
    alpha_max_deg: float = 12.0
    kappa_max: float = 0.3
    combined_alpha_deg: tuple[float, ...] = (3.0, 6.0)
    combined_kappa_max: float = 0.25
    camber_sweep_deg: float = 8.0
    camber_alpha_gamma_deg: tuple[float, ...] = (-4.0, 4.0)
    camber_alpha_max_deg: float = 10.0
    rr_speeds: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0)
    eigen_pressures_bar: tuple[float, ...] = (1.9, 2.2, 2.5, 2.7, 3.0)
    samples: Samples = Samples()


#: The thesis grid (5 pressures x 3 loads; CFx at 2/4/6 kN; parking at 1..6 kN).
FULL = Grid(name="full")

#: A reduced grid for tests: 2 pressures, 2 loads, 2 start positions, few samples.
SMALL = Grid(
    name="small", pressures_bar=(2.2, 2.8), loads=(3000.0, 6000.0), long_loads=(2000.0, 5000.0),
    parking_loads=(2000.0, 5000.0), starts=2, camber_deg=(-10.0, 0.0, 10.0),
    trailer_pressures_bar=(2.2, 2.8), trailer_loads=(3000.0, 6000.0), combined_alpha_deg=(4.0,),
    camber_alpha_gamma_deg=(4.0,), rr_speeds=(10.0, 25.0), eigen_pressures_bar=(2.2, 2.8),
    samples=Samples(vertical=60, stiffness=60, parking=120, rolling=60, free_rolling=20,
                    camber=20, lead_in=4, trailer_alpha=41, trailer_kappa=41,
                    trailer_combined=41, trailer_camber=33, trailer_rr=5),
)

GRIDS = {"full": FULL, "small": SMALL}
