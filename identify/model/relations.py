"""Inflation-pressure relations of op het Veld (2007) as pure vectorised functions.

Every relation of ``docs/relations.md``: vertical force and stiffness (qFz and
Magic Formula forms), the load-and-pressure stiffness form of CFx and CFy, the yaw stiffness
forms T1 and T2, the cornering stiffness Kya with PPY1/PPY2, the lateral relaxation length (ratio
and carcass-chain forms), rolling resistance (new power-law form and old form), the camber
stiffness with PPY5, the sidewall-stiffness scaling with its eigenfrequencies and the Rotta
membrane variant.

Arguments broadcast like numpy ufuncs; nothing here does I/O or keeps state. Pressures may be
given in any unit as long as ``p`` and ``p0`` share it (the relations only see ``dpi``). A small
frozen dataclass per relation bundles its coefficients (``to_dict()`` is JSON-safe).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from identify.core.serial import Serial

__all__ = [
    "dpi", "dfz",
    "fz_qfz", "cfz_qfz", "rho_qfz", "cfz_qfz_at_load", "fz_mf", "cfz_mf", "mf_from_qfz",
    "qfz_from_mf", "VerticalQFz",
    "load_pressure_stiffness", "LoadPressureStiffness",
    "cmz_t1", "cmz_t2", "YawT1", "YawT2",
    "kya", "sigma_ratio", "contact_half_length", "carcass_compliance", "cfy_chain",
    "sigma_chain", "CorneringStiffness",
    "fxrr_new", "fxrr_old", "RollingResistance",
    "kyg0",
    "sidewall_scaled", "eigenfrequency", "rotta_membrane", "rotta_ring", "RING_MODES",
    "SidewallRing",
]


class _Coefficients(Serial):
    """Base of the relation dataclasses: the fields are the relation's coefficients, in the
    order its functions take them after the operating point (``to_dict``: field by field)."""

    def coefficients(self) -> tuple:
        return tuple(getattr(self, f.name) for f in fields(self))


class _LoadPressureRelation(_Coefficients):
    """A relation of load ``fz`` [N] and pressure increment ``dp`` [-]: calling it evaluates
    ``function(fz, dp, *coefficients)`` (units in the function's docstring)."""

    function: ClassVar[Callable]

    def __call__(self, fz, dp):
        return self.function(fz, dp, *self.coefficients())


def _f(x):
    return np.asarray(x, dtype=float)


def dpi(p, p0):
    """Normalised pressure increment (p - p0)/p0 [-]; ``p`` and ``p0`` in one unit."""
    return (_f(p) - p0) / p0


def dfz(fz, fz0):
    """Normalised load increment (Fz - Fz0)/Fz0 [-]; ``fz`` and ``fz0`` [N]."""
    return (_f(fz) - fz0) / fz0


# --- vertical --------------------------------------------------------------------------------

def fz_qfz(rho, dp, qfz1, qfz2, qfz3):
    """Vertical force Fz = (1 + qFz3 dpi)(qFz1 rho + qFz2 rho^2) [N].

    Parameters
    ----------
    rho : array_like
        Vertical deflection [m].
    dp : array_like
        Pressure increment dpi [-].
    qfz1 : float
        Linear stiffness term [N/m].
    qfz2 : float
        Quadratic term [N/m^2].
    qfz3 : float
        Pressure term [-].
    """
    rho = _f(rho)
    return (1 + qfz3 * _f(dp)) * (qfz1 * rho + qfz2 * rho ** 2)


def cfz_qfz(rho, dp, qfz1, qfz2, qfz3):
    """Vertical stiffness CFz = dFz/drho = (1 + qFz3 dpi)(qFz1 + 2 qFz2 rho) [N/m]."""
    return (1 + qfz3 * _f(dp)) * (qfz1 + 2 * qfz2 * _f(rho))


def rho_qfz(fz, dp, qfz1, qfz2, qfz3):
    """Deflection rho [m] at load ``fz`` [N]: the root >= 0 of the qFz relation.

    Uses the cancellation-free form 2 f / (q1 + sqrt(q1^2 + 4 q2 f)), f = Fz/(1 + qFz3 dpi),
    which also covers qFz2 = 0.
    """
    f = _f(fz) / (1 + qfz3 * _f(dp))
    return 2 * f / (qfz1 + np.sqrt(qfz1 ** 2 + 4 * qfz2 * f))


def cfz_qfz_at_load(fz, dp, qfz1, qfz2, qfz3):
    """Vertical stiffness at a load [N/m].

    CFz = (1 + qFz3 dpi) sqrt(qFz1^2 + 4 qFz2 Fz/(1 + qFz3 dpi)), ``fz`` [N].
    """
    k = 1 + qfz3 * _f(dp)
    return k * np.sqrt(qfz1 ** 2 + 4 * qfz2 * _f(fz) / k)


def mf_from_qfz(qfz1, qfz2, qfz3, r0, fz0):
    """MF 6.x vertical keys (docs/model.md, section 10.2) equivalent to a qFz relation.

    Returns
    -------
    dict
        ``VERTICAL_STIFFNESS`` [N/m] (CFz at Fz0, p0), ``Q_FZ2`` [-], ``PFZ1`` [-]; the MF's
        derived Q_FZ1 then equals qFz1 R0/Fz0.
    """
    return {"VERTICAL_STIFFNESS": float(np.sqrt(qfz1 ** 2 + 4 * qfz2 * fz0)),
            "Q_FZ2": float(qfz2 * r0 ** 2 / fz0), "PFZ1": float(qfz3)}


def qfz_from_mf(vertical_stiffness, q_fz2, pfz1, r0, fz0):
    """qFz1 [N/m], qFz2 [N/m^2], qFz3 [-] of the MF form (inverse of :func:`mf_from_qfz`)."""
    q_fz1 = np.sqrt((vertical_stiffness * r0 / fz0) ** 2 - 4 * q_fz2)
    return float(q_fz1 * fz0 / r0), float(q_fz2 * fz0 / r0 ** 2), float(pfz1)


def fz_mf(rho, dp, vertical_stiffness, q_fz2, pfz1, r0, fz0):
    """MF form Fz = (1 + PFZ1 dpi) Fz0 (Q_FZ1 x + Q_FZ2 x^2), x = rho/R0 [N].

    Q_FZ1 = sqrt((VERTICAL_STIFFNESS R0/Fz0)^2 - 4 Q_FZ2) as in MFeval (no speed or force terms).
    ``vertical_stiffness`` [N/m], ``r0`` [m], ``fz0`` [N], ``rho`` [m].
    """
    q_fz1 = np.sqrt((vertical_stiffness * r0 / fz0) ** 2 - 4 * q_fz2)
    x = _f(rho) / r0
    return (1 + pfz1 * _f(dp)) * fz0 * (q_fz1 * x + q_fz2 * x ** 2)


def cfz_mf(rho, dp, vertical_stiffness, q_fz2, pfz1, r0, fz0):
    """MF form vertical stiffness dFz/drho [N/m] (see :func:`fz_mf`)."""
    q_fz1 = np.sqrt((vertical_stiffness * r0 / fz0) ** 2 - 4 * q_fz2)
    return (1 + pfz1 * _f(dp)) * (fz0 / r0) * (q_fz1 + 2 * q_fz2 * _f(rho) / r0)


@dataclass(frozen=True)
class VerticalQFz(_Coefficients):
    """qFz vertical relation: qfz1 [N/m], qfz2 [N/m^2], qfz3 [-]."""

    qfz1: float
    qfz2: float
    qfz3: float

    def fz(self, rho, dp):
        """Fz [N] at deflection ``rho`` [m]."""
        return fz_qfz(rho, dp, *self.coefficients())

    def cfz(self, rho, dp):
        """CFz [N/m] at deflection ``rho`` [m]."""
        return cfz_qfz(rho, dp, *self.coefficients())

    def rho(self, fz, dp):
        """Deflection [m] at load ``fz`` [N]."""
        return rho_qfz(fz, dp, *self.coefficients())

    def cfz_at_load(self, fz, dp):
        """CFz [N/m] at load ``fz`` [N]."""
        return cfz_qfz_at_load(fz, dp, *self.coefficients())


# --- CFx, CFy --------------------------------------------------------------------------------

def load_pressure_stiffness(fz, dp, nominal, p1, p2, p3, fz0):
    """C = C_nom (1 + p1 dfz + p2 dfz^2)(1 + p3 dpi) [N/m] (CFx and CFy).

    ``fz`` [N], ``dp`` [-], ``nominal`` C at Fz0 and p0 [N/m], ``fz0`` the relation's reference
    load [N] (the thesis used 4 kN for CFx, 5 kN for CFy).
    """
    d = dfz(fz, fz0)
    return nominal * (1 + p1 * d + p2 * d ** 2) * (1 + p3 * _f(dp))


@dataclass(frozen=True)
class LoadPressureStiffness(_LoadPressureRelation):
    """CFx or CFy relation: nominal [N/m], p1, p2, p3 [-], fz0 [N]; called: the stiffness [N/m]
    at load ``fz`` [N] and pressure increment ``dp`` [-]."""

    nominal: float
    p1: float
    p2: float
    p3: float
    fz0: float
    function = staticmethod(load_pressure_stiffness)

    def rebased(self, fz0: float) -> LoadPressureStiffness:
        """The identical relation written with another reference load ``fz0`` [N].

        The load polynomial is re-expanded exactly (e.g. a CFx measured with Fz0 = 4 kN written
        for a .tir whose FNOMIN is 5 kN).
        """
        k = fz0 / self.fz0
        c = (fz0 - self.fz0) / self.fz0
        ratio = 1 + self.p1 * c + self.p2 * c ** 2
        p1 = (self.p1 * k + 2 * self.p2 * k * c) / ratio
        return LoadPressureStiffness(self.nominal * ratio, p1, self.p2 * k ** 2 / ratio, self.p3,
                                     fz0)


# --- CMz ---------------------------------------------------------------------------------------

def cmz_t1(fz, dp, nominal, p1, fz0):
    """Yaw stiffness form T1: CMz = CMz_nom (1 + pCMz1 dpi) Fz/Fz0 [N m/rad]."""
    return nominal * (1 + p1 * _f(dp)) * _f(fz) / fz0


def cmz_t2(fz, dp, nominal, p1, p2, p3, fz0):
    """Yaw stiffness form T2: CMz_nom (pCMz1 Fz/Fz0 + pCMz2 (Fz/Fz0)^2)(1 + pCMz3 dpi) [N m/rad]."""
    r = _f(fz) / fz0
    return nominal * (p1 * r + p2 * r ** 2) * (1 + p3 * _f(dp))


class _YawStiffness(_LoadPressureRelation):
    """A CMz form; ``to_dict`` names it (``form``, first)."""

    form: ClassVar[str]
    serial_derived = {"form": lambda self: self.form}
    serial_order = ("form",)


@dataclass(frozen=True)
class YawT1(_YawStiffness):
    """CMz form T1: nominal [N m/rad], p1 [-], fz0 [N]."""

    nominal: float
    p1: float
    fz0: float
    function = staticmethod(cmz_t1)
    form = "T1"


@dataclass(frozen=True)
class YawT2(_YawStiffness):
    """CMz form T2: nominal [N m/rad], p1, p2, p3 [-], fz0 [N]."""

    nominal: float
    p1: float
    p2: float
    p3: float
    fz0: float
    function = staticmethod(cmz_t2)
    form = "T2"


# --- cornering stiffness and relaxation length -------------------------------------------------

def kya(fz, dp, pky1, pky2, ppy1, ppy2, fz0, pky4=2.0):
    """Cornering stiffness PKY1 (1 + PPY1 dpi) Fz0 sin(PKY4 atan(Fz/(PKY2 (1 + PPY2 dpi) Fz0))).

    Zero camber, unit scaling factors [N/rad]; negative for an ISO-W file (PKY1 < 0).
    """
    dp = _f(dp)
    return pky1 * (1 + ppy1 * dp) * fz0 * np.sin(
        pky4 * np.arctan(_f(fz) / (pky2 * (1 + ppy2 * dp) * fz0)))


def sigma_ratio(kya_value, cfy):
    """Relaxation length sigma = |Kya| / CFy [m] (``kya_value`` [N/rad], ``cfy`` [N/m])."""
    return np.abs(_f(kya_value)) / _f(cfy)


def contact_half_length(rho, r0, pa1, pa2):
    """Half contact length a = pa1 r0 (rho/r0 + pa2 sqrt(rho/r0)) [m] (``rho``, ``r0`` [m])."""
    x = _f(rho) / r0
    return pa1 * r0 * (x + pa2 * np.sqrt(x))


def carcass_compliance(c_r, c_b, c_bphi, rl):
    """Carcass compliance 1/c = 1/c_r + 1/c_b + rl^2/c_bphi [m/N].

    ``c_r`` residual stiffness [N/m], ``c_b`` sidewall translational stiffness [N/m], ``c_bphi``
    sidewall rotational stiffness (c_bgamma for lateral, c_btheta for longitudinal) [N m/rad],
    ``rl`` loaded radius [m].
    """
    return 1 / _f(c_r) + 1 / _f(c_b) + _f(rl) ** 2 / _f(c_bphi)


def cfy_chain(cfalpha, c_y, a):
    """Overall stiffness of the carcass chain, 1/CF = 1/c + a/CFalpha [N/m].

    ``cfalpha`` slip stiffness magnitude [N/rad], ``c_y`` carcass stiffness [N/m], ``a`` [m].
    """
    return 1 / (1 / _f(c_y) + _f(a) / np.abs(_f(cfalpha)))


def sigma_chain(cfalpha, c_y, a):
    """Relaxation length of the carcass chain, sigma = CFalpha/c + a [m]."""
    return np.abs(_f(cfalpha)) / _f(c_y) + _f(a)


@dataclass(frozen=True)
class CorneringStiffness(_LoadPressureRelation):
    """Kya relation: pky1, pky2, ppy1, ppy2, pky4 [-], fz0 [N]; called: Kya [N/rad]."""

    pky1: float
    pky2: float
    ppy1: float
    ppy2: float
    fz0: float
    pky4: float = 2.0
    function = staticmethod(kya)


# --- rolling resistance ------------------------------------------------------------------------

def _rr_bracket(fz, fx, vx, gamma, q, fz0, vref):
    g2 = _f(gamma) ** 2
    v = _f(vx) / vref
    return (q[0] + q[1] * _f(fx) / fz0 + q[2] * np.abs(v) + q[3] * v ** 4
            + q[4] * g2 + q[5] * (_f(fz) / fz0) * g2)


def fxrr_new(fz, p, fx, vx, gamma, qsy, p0, fz0, vref, lmy=1.0):
    """Rolling-resistance force, new form with QSY7/QSY8 power laws [N].

    Fx,RR = -Fz0 lMy (qsy1 + qsy2 Fx/Fz0 + qsy3 |Vx/Vref| + qsy4 (Vx/Vref)^4 + qsy5 g^2
    + qsy6 (Fz/Fz0) g^2) (Fz/Fz0)^qsy7 (p/p0)^qsy8.

    Parameters
    ----------
    fz, fx : array_like [N]
    p : array_like       pressure, same unit as ``p0``
    vx : array_like [m/s]
    gamma : array_like [rad]
    qsy : sequence of 8 floats
        qsy1..qsy8 [-]; the power laws act on Fz/Fz0 and p/p0 (never on dfz, dpi).
    fz0 : float [N]
    vref : float [m/s]
    """
    q = tuple(qsy)
    return (-fz0 * lmy * _rr_bracket(fz, fx, vx, gamma, q, fz0, vref)
            * (_f(fz) / fz0) ** q[6] * (_f(p) / p0) ** q[7])


def fxrr_old(fz, fx, vx, gamma, qsy, fz0, vref, lmy=1.0):
    """Rolling-resistance force, old form -Fz lMy (same bracket) [N] (qsy7 = 1, qsy8 = 0).

    ``qsy`` holds qsy1..qsy6 (further entries are ignored).
    """
    q = tuple(qsy)
    return -_f(fz) * lmy * _rr_bracket(fz, fx, vx, gamma, q, fz0, vref)


@dataclass(frozen=True)
class RollingResistance(Serial):
    """Rolling-resistance coefficients qsy1..qsy8 [-], p0 [Pa], fz0 [N], vref [m/s]."""

    qsy: tuple[float, ...]
    p0: float
    fz0: float
    vref: float

    def __call__(self, fz, p, fx, vx, gamma):
        return fxrr_new(fz, p, fx, vx, gamma, self.qsy, self.p0, self.fz0, self.vref)


# --- camber ------------------------------------------------------------------------------------

def kyg0(fz, dp, pky6, pky7, ppy5, fz0, lkyc=1.0):
    """Camber stiffness Kyg0 = (PKY6 + PKY7 dfz) Fz lKyg (1 + PPY5 dpi) [N/rad]."""
    return (pky6 + pky7 * dfz(fz, fz0)) * _f(fz) * lkyc * (1 + ppy5 * _f(dp))


# --- sidewall (rigid ring) ---------------------------------------------------------------------

def sidewall_scaled(c0, f, dp):
    """Sidewall stiffness scaled linearly with pressure, c_b = c_b0 (1 + f dpi) (unit of c0)."""
    return _f(c0) * (1 + _f(f) * _f(dp))


def eigenfrequency(c, m):
    """Undamped eigenfrequency sqrt(c/m)/(2 pi) [Hz] (c [N/m] with m [kg], or [N m/rad] with
    a moment of inertia [kg m^2])."""
    return np.sqrt(_f(c) / _f(m)) / (2 * np.pi)


def rotta_membrane(p, g_mod, t, l_s, phi_s):
    """Rotta directional sidewall stiffnesses per unit circumference [N/m^2].

    c_u = G t/l_s + p/tan(phi_s); c_w = p (cos phi_s + phi_s sin phi_s)/(sin phi_s - phi_s cos
    phi_s); c_v = p sin g/(1 + cos g - (pi - g)/(2 sin g)) as printed in the source, with the
    angle g taken as phi_s.

    Parameters
    ----------
    p : array_like [Pa]
    g_mod : float      shear modulus G [N/m^2]
    t : float          sidewall thickness [m]
    l_s : float        sidewall length [m]
    phi_s : float      sidewall angle [rad]

    Returns
    -------
    tuple of ndarray
        (c_u, c_v, c_w) [N/m^2].
    """
    p = _f(p)
    s, c = np.sin(phi_s), np.cos(phi_s)
    c_u = g_mod * t / l_s + p / np.tan(phi_s)
    c_w = p * (c + phi_s * s) / (s - phi_s * c)
    c_v = p * s / (1 + c - (np.pi - phi_s) / (2 * s))
    return c_u, c_v, c_w


def rotta_ring(p, r, g_mod, t, l_s, phi_s):
    """Rigid-ring sidewall stiffnesses from Rotta membrane theory.

    Returns
    -------
    dict of ndarray
        ``x``, ``z`` = pi r (c_u + c_w), ``y`` = 2 pi r c_v [N/m]; ``gamma``, ``psi`` =
        pi r^3 c_v, ``theta`` = 2 pi r^3 c_u [N m/rad]. ``r`` is the ring radius [m].
    """
    c_u, c_v, c_w = rotta_membrane(p, g_mod, t, l_s, phi_s)
    cxz = np.pi * r * (c_u + c_w)
    crot = np.pi * r ** 3 * c_v
    return {"x": cxz, "y": 2 * np.pi * r * c_v, "z": cxz, "theta": 2 * np.pi * r ** 3 * c_u,
            "gamma": crot, "psi": crot}


#: The six rigid-ring modes in the order used everywhere.
RING_MODES = ("x", "y", "z", "theta", "gamma", "psi")


@dataclass(frozen=True)
class SidewallRing(Serial):
    """Rigid-ring sidewall stiffnesses at p0 and their pressure scaling.

    Attributes
    ----------
    c0 : tuple of 6 floats
        c_bx, c_by, c_bz [N/m], c_btheta, c_bgamma, c_bpsi [N m/rad] at p0.
    f : tuple of 6 floats
        Pressure scaling f_x .. f_psi [-].
    m_b : float
        Ring (belt) mass [kg].
    i_bx, i_by : float
        Ring diametral and polar moments of inertia [kg m^2] (I_bz = I_bx).
    """

    c0: tuple[float, ...]
    f: tuple[float, ...]
    m_b: float
    i_bx: float
    i_by: float

    def stiffness(self, mode: str, dp):
        """Sidewall stiffness of one mode at pressure increment ``dp``."""
        k = RING_MODES.index(mode)
        return sidewall_scaled(self.c0[k], self.f[k], dp)

    def inertia(self, mode: str) -> float:
        """Mass [kg] or moment of inertia [kg m^2] that goes with ``mode``."""
        return {"theta": self.i_by, "gamma": self.i_bx, "psi": self.i_bx}.get(mode, self.m_b)

    def frequency(self, mode: str, dp):
        """Free-hanging (fixed rim) eigenfrequency of ``mode`` [Hz]."""
        return eigenfrequency(self.stiffness(mode, dp), self.inertia(mode))

    #: ``to_dict`` names the modes (first) that ``c0`` and ``f`` go with
    serial_derived = {"modes": lambda self: list(RING_MODES)}
    serial_order = ("modes",)
