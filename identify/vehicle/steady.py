"""Steady-state cornering (ISO 4138): the two-track quasi-static solve and the handling diagram.

Model (docs/vehicle.md, "Steady state"). At a lateral acceleration ay the car is in yaw and
lateral equilibrium with free-rolling tyres:

    Fy_front + Fy_rear = m ay,        a Fy_front = b Fy_rear
    =>  Fy_front = m ay b / wb,         Fy_rear = m ay a / wb

Each axle carries its share with two wheels whose loads differ by the lateral load transfer

    dFz_axle = m ay h k_axle / (k_front + k_rear) / track_axle

(the roll moment m ay h split by roll stiffness, roll centres on the ground). Each wheel runs
at the axle's slip angle alpha_axle corrected by its static toe and by compliance steer,

    alpha_wheel = alpha_axle -/+ toe - c_Fy Fy_wheel(alpha_wheel) + c_Mz Mz_wheel(alpha_wheel)

solved per wheel by Newton's method. alpha_axle (the slip angle of the axle as the body sees
it, compliance included) is found from the axle force by Newton's method on the rising branch
of the axle characteristic, below its peak. The handling diagram plots ay against
alpha_rear - alpha_front; the understeer gradient is d(alpha_front - alpha_rear)/d ay at
vanishing ay. The maximum lateral acceleration is where the first axle reaches its peak force.
The aligning moments act through the compliance; their direct yaw moment on the body, the
drive force needed to hold speed and the differences of slip angle across a track are not
modelled (the single-track simplifications).

Every function is vectorised over operating points (settings x lateral accelerations).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from identify.vehicle.spec import G, Vehicle
from identify.vehicle.tyre import AxleTyre, wheel_lateral

__all__ = ["AxleSetup", "AxleSolution", "axle_setups", "axle_force", "axle_peak", "solve_axle",
           "wheel_loads", "handling_points", "max_lateral_acceleration",
           "axle_cornering_stiffness", "understeer_gradient", "ALPHA_GRID"]

ALPHA_GRID = np.linspace(0.0, 0.4, 41)
"""Axle slip angles [rad] on which the axle characteristic is sampled to find its peak."""
_NEWTON = 10
_H = 1e-6  # finite-difference step of the slip derivatives [rad]


@dataclass(frozen=True)
class AxleSetup:
    """One axle's wheel settings.

    Attributes
    ----------
    axle : str                 "front" or "rear"
    camber_rad : float [rad]   static camber (negative: top towards the car)
    toe_rad : float [rad]      static toe-in per wheel
    c_fy : float [rad/N]       compliance steer per wheel force (reduces the slip when > 0)
    c_mz : float [rad/(N m)]   compliance steer per wheel aligning moment
    """

    axle: str
    camber_rad: float = 0.0
    toe_rad: float = 0.0
    c_fy: float = 0.0
    c_mz: float = 0.0

    def rigid(self) -> AxleSetup:
        """The same axle without compliance steer."""
        return AxleSetup(self.axle, self.camber_rad, self.toe_rad)


def axle_setups(v: Vehicle) -> tuple[AxleSetup, AxleSetup]:
    """Front and rear :class:`AxleSetup` of a vehicle (degrees converted to radians)."""
    d = math.pi / 180
    return (AxleSetup("front", v.static_camber_front_deg * d, v.static_toe_front_deg * d,
                      v.steer_compliance_fy_front_deg_per_N * d,
                      v.steer_compliance_mz_front_deg_per_Nm * d),
            AxleSetup("rear", v.static_camber_rear_deg * d, v.static_toe_rear_deg * d,
                      v.steer_compliance_fy_rear_deg_per_N * d,
                      v.steer_compliance_mz_rear_deg_per_Nm * d))


def wheel_loads(v: Vehicle, axle: str, ay) -> tuple[np.ndarray, np.ndarray]:
    """Left and right wheel loads [N] of ``axle`` at lateral acceleration ``ay`` [m/s^2]
    (positive: a left-hand turn, the right wheels outside). A wheel that would carry a
    negative load has lifted: its load is 0."""
    ay = np.asarray(ay, float)
    f0 = v.static_wheel_load(axle)
    d = v.load_transfer_per_ay(axle) * ay
    return np.maximum(f0 - d, 0.0), np.maximum(f0 + d, 0.0)


@dataclass(frozen=True)
class AxleSolution:
    """An axle at its operating points (arrays of one shape).

    Attributes
    ----------
    alpha : ndarray [rad]              axle slip angle as the body sees it
    force : ndarray [N]                axle lateral force (positive to the left)
    alpha_left, alpha_right : ndarray [rad]   wheel slip angles (vehicle sense)
    fz_left, fz_right : ndarray [N]
    mz : ndarray [N m]                 sum of the two aligning moments
    """

    alpha: np.ndarray
    force: np.ndarray
    alpha_left: np.ndarray
    alpha_right: np.ndarray
    fz_left: np.ndarray
    fz_right: np.ndarray
    mz: np.ndarray


def _wheels(tyre: AxleTyre, ax: AxleSetup, fz_l, fz_r, alpha, p):
    """Wheel slips, forces and moments of both wheels at axle slip ``alpha`` (arrays of one
    shape); Newton's method on the compliance equation."""
    fz_l, fz_r, alpha, p = np.broadcast_arrays(*(np.asarray(x, float)
                                                 for x in (fz_l, fz_r, alpha, p)))
    shape = alpha.shape
    fz = np.concatenate([fz_l.ravel(), fz_r.ravel()])
    side = np.concatenate([np.ones(alpha.size), -np.ones(alpha.size)])
    target = np.concatenate([alpha.ravel() - ax.toe_rad, alpha.ravel() + ax.toe_rad])
    pp = np.concatenate([p.ravel(), p.ravel()])
    camber = ax.camber_rad
    a = target.copy()
    if ax.c_fy != 0.0 or ax.c_mz != 0.0:
        n = a.size
        for _ in range(_NEWTON):
            fy, mz = wheel_lateral(tyre, np.tile(fz, 2), np.concatenate([a, a + _H]),
                                   np.tile(side, 2), camber, np.tile(pp, 2))
            res = a - target + ax.c_fy * fy[:n] - ax.c_mz * mz[:n]
            slope = 1.0 + (ax.c_fy * (fy[n:] - fy[:n]) - ax.c_mz * (mz[n:] - mz[:n])) / _H
            a = a - res / np.maximum(slope, 0.05)
            if np.all(np.abs(res) < 1e-12):
                break
    fy, mz = wheel_lateral(tyre, fz, a, side, camber, pp)
    n = alpha.size
    return (a[:n].reshape(shape), a[n:].reshape(shape), fy[:n].reshape(shape),
            fy[n:].reshape(shape), (mz[:n] + mz[n:]).reshape(shape))


def axle_force(tyre: AxleTyre, ax: AxleSetup, fz_l, fz_r, alpha, p) -> AxleSolution:
    """The axle at slip angle ``alpha`` [rad] with wheel loads ``fz_l``, ``fz_r`` [N] and
    pressure ``p`` [Pa] (arrays broadcast)."""
    al, ar, fl, fr, mz = _wheels(tyre, ax, fz_l, fz_r, alpha, p)
    fz_l, fz_r = np.broadcast_arrays(np.asarray(fz_l, float), np.asarray(fz_r, float))
    return AxleSolution(np.broadcast_to(np.asarray(alpha, float), al.shape), fl + fr, al, ar,
                        np.broadcast_to(fz_l, al.shape), np.broadcast_to(fz_r, al.shape), mz)


def _curve(tyre, ax, fz_l, fz_r, p) -> np.ndarray:
    """Axle force on :data:`ALPHA_GRID` for every point: shape (n, len(ALPHA_GRID))."""
    fz_l, fz_r, p = (np.asarray(x, float).reshape(-1, 1) for x in
                     np.broadcast_arrays(np.asarray(fz_l, float), np.asarray(fz_r, float),
                                         np.asarray(p, float)))
    return axle_force(tyre, ax, fz_l, fz_r, ALPHA_GRID[None, :], p).force


def _peak_from_curve(curve: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peak force, its slip angle (parabola through the largest sample and its neighbours)
    and the index of the largest sample, per row."""
    i = np.argmax(curve, axis=1)
    rows = np.arange(curve.shape[0])
    inner = np.clip(i, 1, len(ALPHA_GRID) - 2)
    f0, f1, f2 = curve[rows, inner - 1], curve[rows, inner], curve[rows, inner + 1]
    h = ALPHA_GRID[1] - ALPHA_GRID[0]
    den = f0 - 2 * f1 + f2
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = np.where(den < 0, 0.5 * (f0 - f2) / den, 0.0)
    shift = np.clip(shift, -1.0, 1.0)
    interior = (i > 0) & (i < len(ALPHA_GRID) - 1)
    peak = np.where(interior, f1 - 0.25 * (f0 - f2) * shift, curve[rows, i])
    alpha = np.where(interior, ALPHA_GRID[inner] + shift * h, ALPHA_GRID[i])
    return peak, alpha, i


def axle_peak(tyre: AxleTyre, ax: AxleSetup, fz_l, fz_r, p) -> tuple[np.ndarray, np.ndarray]:
    """The largest lateral force of the axle [N] and the axle slip angle where it is reached
    [rad], per point (flattened). Where the characteristic still rises at the end of
    :data:`ALPHA_GRID`, its last value and slip angle."""
    peak, alpha, _ = _peak_from_curve(_curve(tyre, ax, fz_l, fz_r, p))
    return peak, alpha


def solve_axle(tyre: AxleTyre, ax: AxleSetup, fz_l, fz_r, f_req, p) -> AxleSolution:
    """The axle slip angle at which the axle gives the force ``f_req`` [N] (>= 0), per point
    (flattened); NaN slip where ``f_req`` exceeds the axle's peak."""
    fz_l, fz_r, f_req, p = (np.asarray(x, float).ravel() for x in np.broadcast_arrays(
        np.asarray(fz_l, float), np.asarray(fz_r, float), np.asarray(f_req, float),
        np.asarray(p, float)))
    curve = _curve(tyre, ax, fz_l, fz_r, p)
    peak, alpha_peak, ipeak = _peak_from_curve(curve)
    reachable = f_req <= peak
    # bracket on the rising branch: the last grid slip below the peak with force <= f_req
    k = np.arange(len(ALPHA_GRID))[None, :]
    below = (curve <= f_req[:, None]) & (k <= ipeak[:, None])
    j = np.clip(np.where(below.any(axis=1), below.shape[1] - 1 - np.argmax(below[:, ::-1],
                                                                           axis=1), 0),
                0, len(ALPHA_GRID) - 2)
    rows = np.arange(len(f_req))
    lo = ALPHA_GRID[j]
    hi = ALPHA_GRID[j + 1]
    # at the largest sample the root lies between its left neighbour and the parabola's peak
    top = j >= ipeak
    lo = np.where(top, ALPHA_GRID[np.maximum(ipeak - 1, 0)], lo)
    hi = np.where(top & (alpha_peak > lo), alpha_peak, hi)
    c0, c1 = curve[rows, j], curve[rows, j + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        a = lo + (ALPHA_GRID[j + 1] - lo) * np.clip((f_req - c0) / (c1 - c0), 0, 1)
    a = np.clip(np.nan_to_num(a, nan=0.0), lo, hi)
    for _ in range(12):
        both = axle_force(tyre, ax, np.tile(fz_l, 2), np.tile(fz_r, 2),
                          np.concatenate([a, a + _H]), np.tile(p, 2)).force
        f, fh = both[:len(a)], both[len(a):]
        res = f - f_req
        done = np.abs(res) <= 1e-10 * np.maximum(np.abs(f_req), 1.0)
        if np.all(done | ~reachable):
            break
        slope = (fh - f) / _H
        step = np.where(slope > 0, res / np.where(slope > 0, slope, 1.0), 0.0)
        new = a - step
        # keep inside the bracket: bisect where Newton would leave it
        lo = np.where(res < 0, np.maximum(lo, a), lo)
        hi = np.where(res > 0, np.minimum(hi, a), hi)
        a = np.where(done, a, np.where((new >= lo) & (new <= hi), new, 0.5 * (lo + hi)))
    a = np.where(reachable, a, np.nan)
    return _with_alpha(axle_force(tyre, ax, fz_l, fz_r, np.nan_to_num(a), p), a)


def _with_alpha(sol: AxleSolution, alpha: np.ndarray) -> AxleSolution:
    bad = ~np.isfinite(alpha)
    nan = lambda x: np.where(bad, np.nan, x)  # noqa: E731
    return AxleSolution(alpha, nan(sol.force), nan(sol.alpha_left), nan(sol.alpha_right),
                        sol.fz_left, sol.fz_right, nan(sol.mz))


def handling_points(tyre: AxleTyre, v: Vehicle, ay, p_front, p_rear
                    ) -> tuple[AxleSolution, AxleSolution]:
    """Front and rear axles at lateral accelerations ``ay`` [m/s^2] (>= 0) and pressures
    [Pa] (arrays broadcast; flattened results). NaN slip where an axle cannot carry its
    share."""
    ay, p_front, p_rear = (np.asarray(x, float).ravel() for x in np.broadcast_arrays(
        np.asarray(ay, float), np.asarray(p_front, float), np.asarray(p_rear, float)))
    front, rear = axle_setups(v)
    m, a, b, wb = v.mass_kg, v.a, v.b, v.wheelbase_m
    out = []
    for ax, share, p in ((front, b, p_front), (rear, a, p_rear)):
        fz_l, fz_r = wheel_loads(v, ax.axle, ay)
        out.append(solve_axle(tyre, ax, fz_l, fz_r, m * ay * share / wb, p))
    return out[0], out[1]


def max_lateral_acceleration(tyre: AxleTyre, v: Vehicle, p_front, p_rear,
                             ay_high: float = 3.0 * G, coarse: int = 16, iterations: int = 14
                             ) -> tuple[np.ndarray, np.ndarray]:
    """The largest steady-state lateral acceleration [m/s^2] per pressure pair, and the axle
    that limits it ("front"/"rear"); NaN and "none" where both axles still carry their share
    at ``ay_high``.

    Each trial ay compares each axle's peak force at that ay's wheel loads with the force the
    axle must carry; the first failing ay of a ``coarse`` grid on [0, ay_high] brackets the
    limit, ``iterations`` bisections narrow it (to ay_high / (coarse - 1) / 2^iterations).
    """
    p_front, p_rear = (np.asarray(x, float).ravel() for x in np.broadcast_arrays(
        np.asarray(p_front, float), np.asarray(p_rear, float)))
    front, rear = axle_setups(v)
    m, a, b, wb = v.mass_kg, v.a, v.b, v.wheelbase_m

    def margins(ay, pf, pr):
        out = []
        for ax, share, p in ((front, b, pf), (rear, a, pr)):
            fz_l, fz_r = wheel_loads(v, ax.axle, ay)
            peak, _ = axle_peak(tyre, ax, fz_l, fz_r, p)
            out.append(peak.reshape(np.shape(ay)) - m * ay * share / wb)
        return out

    n = p_front.size
    grid = np.linspace(0.0, ay_high, coarse)
    ays = np.broadcast_to(grid, (n, coarse))
    mf, mr = margins(ays, p_front[:, None], p_rear[:, None])
    ok = (mf >= 0) & (mr >= 0)
    never = ok.all(axis=1)
    first_bad = np.where(never, coarse - 1, np.argmin(ok, axis=1))
    lo = grid[np.maximum(first_bad - 1, 0)]
    hi = grid[first_bad]
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        mf, mr = margins(mid, p_front, p_rear)
        good = (mf >= 0) & (mr >= 0)
        lo = np.where(good, mid, lo)
        hi = np.where(good, hi, mid)
    mf, mr = margins(hi, p_front, p_rear)
    limiting = np.where(never, "none", np.where(mf < mr, "front", "rear"))
    return np.where(never, np.nan, lo), limiting


def axle_cornering_stiffness(tyre: AxleTyre, ax: AxleSetup, fz, p,
                             step: float = 1e-4) -> np.ndarray:
    """Cornering stiffness of an axle [N/rad], both wheels at load ``fz`` [N] and pressure
    ``p`` [Pa]: the central difference of the axle force over the axle slip angle, compliance
    steer, camber and toe included (use ``ax.rigid()`` for the tyres alone)."""
    fz, p = np.broadcast_arrays(np.asarray(fz, float).ravel(), np.asarray(p, float).ravel())
    alpha = np.concatenate([np.full(fz.size, step), np.full(fz.size, -step)])
    f = axle_force(tyre, ax, np.tile(fz, 2), np.tile(fz, 2), alpha, np.tile(p, 2)).force
    return (f[:fz.size] - f[fz.size:]) / (2 * step)


def understeer_gradient(tyre: AxleTyre, v: Vehicle, p_front, p_rear,
                        ay: float = 0.01) -> np.ndarray:
    """Understeer gradient d(alpha_front - alpha_rear)/d ay [rad/(m/s^2)] at vanishing
    lateral acceleration, per pressure pair: the difference quotient at ``ay`` [m/s^2] (the
    handling curve is odd in ay, so its error is of order ay^2)."""
    f, r = handling_points(tyre, v, ay, p_front, p_rear)
    return (f.alpha - r.alpha) / ay
