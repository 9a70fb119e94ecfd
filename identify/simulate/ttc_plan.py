"""The test programme of a simulated Tire Test Consortium (TTC) session: set points per sample.

A TTC session on a flat-belt machine has a cornering run and a drive/brake run, each in
pressure blocks (:data:`PRESSURE_FACTORS` of NOMPRES, the nominal pressure first, as the TTC
runs 12, 10, 14 psi). A block starts with the belt speeding up (first block) or with the tyre
lifted while the pressure is changed (the tread cools), then a warm-up (the slip angle
oscillating at a load that is not a set point; a mere second in the last block, so that its
first sweep starts on a cold tread), then per camber step the load steps, each with a continuous
sweep between a ramp (transition) and a short settle at zero slip:

- cornering: camber 0, 2, 4 deg, loads :data:`LOAD_FACTORS` of FNOMIN in TTC's shuffled order,
  slip angle 0 -> +A -> -A -> 0 (A = 12 deg);
- drive/brake: camber 0, 2 deg, set slip angles 0, 3, 6 deg (ISO-W; -3, -6 in the file's SAE),
  the same loads, slip ratio 0 -> +k -> -k -> 0 (k = 0.15).

:func:`programme` returns per-sample set points (the clean "intent" of the machine) and the
segments (kind, sample range, set points) that ``truth.json`` records. Durations are jittered
by the seed; everything is vectorised but the loop over the few hundred segments.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from identify.core.serial import Serial

__all__ = [
    "LOAD_FACTORS",
    "PRESSURE_FACTORS",
    "RATE",
    "Programme",
    "SessionPlan",
    "programme",
    "session_plan",
]

#: Sample rate [Hz].
RATE = 100.0
#: Load set points as fractions of FNOMIN, in the order a camber step runs them.
LOAD_FACTORS = (1.0, 0.5, 1.5, 1.25, 0.75)
#: Pressure set points as fractions of NOMPRES, in block order.
PRESSURE_FACTORS = (1.0, 0.85, 1.15)
#: Warm-up load as a fraction of FNOMIN (between two set points on purpose).
WARMUP_LOAD = 1.1
LIFTED_LOAD = 0.02
KIND_CODES = {"start": 0, "pressure_change": 1, "warmup": 2, "transition": 3, "sweep": 4}


@dataclass(frozen=True)
class SessionPlan(Serial):
    """Set points of a session [SI; angles in deg, ISO-W signs]."""

    pressures_Pa: tuple[float, ...]
    loads_N: tuple[float, ...]
    cornering_cambers_deg: tuple[float, ...] = (0.0, 2.0, 4.0)
    drive_cambers_deg: tuple[float, ...] = (0.0, 2.0)
    drive_slip_angles_deg: tuple[float, ...] = (0.0, 3.0, 6.0)
    speed_mps: float = 40.0 / 3.6
    sweep_alpha_deg: float = 12.0
    sweep_kappa: float = 0.15
    warmup_load_N: float = 0.0
    lifted_load_N: float = 0.0



def session_plan(fnomin: float, nompres: float) -> SessionPlan:
    """The set points for a tyre of nominal load ``fnomin`` [N] and pressure ``nompres`` [Pa]
    (pressures rounded to 1 kPa, loads to 10 N)."""
    return SessionPlan(tuple(float(round(nompres * f, -3)) for f in PRESSURE_FACTORS),
                       tuple(float(round(fnomin * f, -1)) for f in LOAD_FACTORS),
                       warmup_load_N=float(round(fnomin * WARMUP_LOAD, -1)),
                       lifted_load_N=float(round(fnomin * LIFTED_LOAD, -1)))


@dataclass
class Programme:
    """Per-sample set points of one run (ISO-W, SI) and its segments."""

    fz: list = field(default_factory=list)
    p: list = field(default_factory=list)
    gamma: list = field(default_factory=list)
    vx: list = field(default_factory=list)
    alpha: list = field(default_factory=list)
    kappa: list = field(default_factory=list)
    kind: list = field(default_factory=list)
    segments: list = field(default_factory=list)
    state: dict = field(default_factory=dict)
    n: int = 0

    def add(self, kind: str, seconds: float, *, fz=None, p=None, gamma=None, vx=None,
            alpha=0.0, kappa=0.0, **setpoints) -> None:
        """Append a segment; a ``(a, b)`` pair ramps from a to b (cosine), None holds."""
        n = samples(seconds)
        s = 0.5 - 0.5 * np.cos(np.pi * np.linspace(0.0, 1.0, n))
        for name, value in (("fz", fz), ("p", p), ("gamma", gamma), ("vx", vx)):
            value = self.state[name] if value is None else value
            if isinstance(value, tuple):
                arr = value[0] + (value[1] - value[0]) * s
                self.state[name] = value[1]
            else:
                arr = np.full(n, float(value))
                self.state[name] = float(value)
            getattr(self, name).append(arr)
        self.alpha.append(np.broadcast_to(np.asarray(alpha, dtype=float), (n,)))
        self.kappa.append(np.broadcast_to(np.asarray(kappa, dtype=float), (n,)))
        self.kind.append(np.full(n, KIND_CODES[kind], dtype=np.int8))
        seg = {"kind": kind, "start": self.n, "stop": self.n + n,
               **{k: float(self.state[k]) for k in ("fz", "p", "gamma", "vx")}, **setpoints}
        self.segments.append(seg)
        self.n += n

    def arrays(self) -> dict[str, np.ndarray]:
        """The set points as arrays (``fz`` [N], ``p`` [Pa], ``gamma``, ``alpha`` [rad],
        ``kappa`` [-], ``vx`` [m/s], ``kind`` code)."""
        out = {k: np.concatenate(getattr(self, k)) for k in ("fz", "p", "gamma", "vx", "alpha",
                                                              "kappa", "kind")}
        for k in ("gamma", "alpha"):
            out[k] = np.deg2rad(out[k])
        return out


def samples(seconds: float) -> int:
    """The number of samples of a segment of ``seconds`` [s] (at least one)."""
    return max(round(float(seconds) * RATE), 1)


def _triangle(amplitude: float, n: int) -> np.ndarray:
    """0 -> +a -> -a -> 0 in ``n`` equally spaced samples."""
    s = np.linspace(0.0, 4.0, n)
    return amplitude * np.where(s <= 1, s, np.where(s <= 3, 2 - s, s - 4))


def _block_start(prog: Programme, plan: SessionPlan, b: int, p_set: float,
                 rng: np.random.Generator, last: bool) -> None:
    if b == 0:
        prog.state.update(fz=plan.warmup_load_N, p=p_set, gamma=0.0, vx=0.0)
        prog.add("start", 3.0, vx=(0.0, plan.speed_mps))
    else:
        j = rng.uniform(0.9, 1.1)
        prog.add("pressure_change", 2.0 * j, fz=(prog.state["fz"], plan.lifted_load_N),
                 gamma=(prog.state["gamma"], 0.0))
        prog.add("pressure_change", 4.0 * j)
        prog.add("pressure_change", 10.0 * j, p=(prog.state["p"], p_set), set_pressure=True)
        prog.add("pressure_change", 2.0 * j)
        prog.add("pressure_change", 2.0 * j, fz=(plan.lifted_load_N, plan.warmup_load_N))
    seconds = 40.0 if b == 0 else rng.uniform(0.5, 1.0) if last else rng.uniform(12.0, 25.0)
    t = np.arange(samples(seconds)) / RATE
    prog.add("warmup", seconds, alpha=4.0 * np.sin(2 * np.pi * 0.4 * t))


def _sweep(prog: Programme, kind: str, seconds: float, amplitude: float, **setpoints) -> None:
    shape = _triangle(amplitude, samples(seconds))
    alpha = setpoints["alpha_deg"]
    if kind == "alpha":
        prog.add("sweep", 0.5, alpha=alpha, sweep="alpha", **setpoints)
        prog.add("sweep", seconds, alpha=shape, sweep="alpha", **setpoints)
        prog.add("sweep", 0.3, alpha=alpha, sweep="alpha", **setpoints)
    else:
        prog.add("sweep", 0.5, alpha=alpha, sweep="kappa", **setpoints)
        prog.add("sweep", seconds, alpha=alpha, kappa=shape, sweep="kappa", **setpoints)
        prog.add("sweep", 0.3, alpha=alpha, sweep="kappa", **setpoints)


def programme(plan: SessionPlan, test: str, seed_rng: np.random.Generator) -> Programme:
    """The set points of one run, ``test`` = ``"cornering"`` or ``"drive_brake"``."""
    prog = Programme()
    rng = seed_rng
    blocks = len(plan.pressures_Pa)
    for b, p_set in enumerate(plan.pressures_Pa):
        _block_start(prog, plan, b, p_set, rng, b == blocks - 1)
        cambers = plan.cornering_cambers_deg if test == "cornering" else plan.drive_cambers_deg
        for c in cambers:
            if c != prog.state["gamma"]:
                prog.add("transition", 1.5, gamma=(prog.state["gamma"], c))
            angles = (0.0,) if test == "cornering" else plan.drive_slip_angles_deg
            current = 0.0
            for a in angles:
                if a != current:
                    prog.add("transition", 1.0, alpha=np.linspace(current, a, samples(1.0)))
                    current = a
                for load in plan.loads_N:
                    j = rng.uniform(0.9, 1.1)
                    prog.add("transition", 1.5 * j, fz=(prog.state["fz"], load), alpha=a)
                    setpoints = {"p_set": p_set, "fz_set": load, "gamma_deg": c,
                                 "alpha_deg": a, "block": b}
                    if test == "cornering":
                        _sweep(prog, "alpha", 8.5 * j, plan.sweep_alpha_deg, **setpoints)
                    else:
                        _sweep(prog, "kappa", 4.8 * j, plan.sweep_kappa, **setpoints)
            if current != 0.0:
                prog.add("transition", 1.0, alpha=np.linspace(current, 0.0, samples(1.0)))
    return prog
