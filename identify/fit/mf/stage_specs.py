"""The MF fitting stages: which coefficients, which data, which model (docs/procedures.md).

Each stage fits one measured quantity on one selection of the trailer points with only its own
coefficients free; everything else is held at the values carried forward from the earlier
stages. The stage models call the forward model's pieces (identify.model) with useMode 211 and
precompute whatever does not depend on the stage's coefficients, so that a prediction is
bit-identical to ``identify.model.evaluate.evaluate(..., mode=211)[quantity]``.

Coefficients are listed in priority order: when the data cannot separate two of them, the later
one is held (identify.fit.mf.screen). ``NEEDS`` states what the data must cover for a
coefficient to be identifiable at all (load, pressure, camber, speed levels, slip signs).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from identify.model import aligning, lateral, longitudinal, moments, vertical
from identify.model.state import OperatingState

PURE_ALPHA = np.deg2rad(0.25)
"""[rad] |alpha| at or below this is pure longitudinal slip."""
PURE_KAPPA = 0.002
"""[-] |kappa| at or below this is pure lateral slip."""


@dataclass(frozen=True)
class StageDef:
    """One MF stage.

    Attributes
    ----------
    name : str             stage name (FitResult.form)
    quantity : str         fitted channel of the trailer table (Fx, Fy, Mz, Mx, My), Rl, the
                           loaded radius (the ``rl`` channel), or Re, the effective rolling
                           radius Vx/omega derived from the wheel speed
                           (identify.fit.mf.stage_data.quantity_values)
    unit : str             its unit
    selection : str        ``"free_rolling"`` (runs without a kappa sweep, |kappa| <= FREE_KAPPA,
                           a wheel speed omega > 0 and Vx >= FREE_MIN_SPEED; see
                           identify.fit.mf.stage_data), ``"longitudinal"`` (|alpha| <= PURE_ALPHA
                           in runs with a kappa sweep),
                           ``"lateral"`` (runs with an alpha or gamma sweep: every point of
                           a run that rolls freely -- no kappa sweep, median |kappa| <=
                           FREE_KAPPA -- whose kappa is the channel's noise, |kappa| <=
                           PURE_KAPPA in the others), ``"combined"`` (|alpha| > PURE_ALPHA
                           and |kappa| > PURE_KAPPA in runs that do not roll freely: a kappa
                           sweep, or an alpha sweep at a held slip ratio),
                           ``"kappa_slip"`` (|kappa| > PURE_KAPPA at any slip angle in runs
                           that do not roll freely, when
                           there are combined points at all: the Fy
                           stage, whose kappa-induced SVyk acts at alpha = 0 too, where only
                           a slip-ratio sweep at zero slip angle pins it),
                           ``"drag"`` (the combined points, and every point of a run that
                           rolls freely at |alpha| > PURE_ALPHA: the Fx stage, whose
                           reduction Gxa at kappa = 0 is the whole of a cornering run's Fx,
                           Gxa(alpha) Fx0(0), the drag the session logs on most of its
                           samples), ``"any_kappa"`` (|kappa| > PURE_KAPPA at any slip angle
                           in runs that do not roll freely: the Mz stage, whose arm s of Fx
                           acts at alpha = 0 as well, where a drive/brake run's Mz is mostly
                           s Fx),
                           ``"rolling_runs"`` (every point of the runs that roll freely --
                           cornering and camber runs: no kappa sweep, no held slip ratio --
                           and every point of the table when it has no such run: the Mx
                           stage, see the note there) or ``"all"``
    coefficients : tuple of str   the stage's own coefficients, priority order
    """

    name: str
    quantity: str
    unit: str
    selection: str
    coefficients: tuple[str, ...]


def _names(text: str) -> tuple[str, ...]:
    return tuple(text.split())


STAGES: dict[str, StageDef] = {s.name: s for s in (
    # Rl = R0 (Q_RE0 + Q_V1 (omega R0/V0)^2) - rho, the deflection rho from the MF load law
    # Fz = (1 + Q_V2 ... - (Q_FCY Fy/Fz0)^2)(1 + PFZ1 dpi) Fz0 (Q_FZ1 rho/R0 + Q_FZ2 (rho/R0)^2),
    # Q_FZ1 from VERTICAL_STIFFNESS (docs/model.md, section 10.3); the geometry stage holds the
    # Q_RE0 and Q_V1 it fits (identify.fit.mf.stages._untaken)
    StageDef("vertical", "Rl", "m", "free_rolling",
             _names("Q_RE0 VERTICAL_STIFFNESS PFZ1 Q_FZ2 Q_V1 Q_V2 Q_FCY")),
    # Re = R0 (Q_RE0 + Q_V1 (omega R0/V0)^2) - Fz0/Cz' (DREFF atan(BREFF Fz/Fz0) + FREFF Fz/Fz0)
    # with Cz' = VERTICAL_STIFFNESS (1 + PFZ1 dpi) held (CFz relation of the Flatplank data)
    StageDef("geometry", "Re", "m", "free_rolling", _names("Q_RE0 Q_V1 DREFF FREFF BREFF")),
    StageDef("Fx0", "Fx", "N", "longitudinal", _names(
        "PDX1 PKX1 PCX1 PEX1 PDX2 PKX2 PEX2 PHX1 PVX1 PHX2 PVX2 PKX3 PEX3 PEX4 "
        "PPX1 PPX3 PPX2 PPX4 PDX3")),
    StageDef("Fy0", "Fy", "N", "lateral", _names(
        "PDY1 PKY1 PCY1 PEY1 PKY2 PDY2 PEY2 PKY4 PHY1 PVY1 PHY2 PVY2 PEY3 "
        "PPY1 PPY2 PPY3 PPY4 PKY6 PKY7 PVY3 PVY4 PDY3 PKY3 PKY5 PEY4 PEY5 PPY5")),
    StageDef("Mz0", "Mz", "N m", "lateral", _names(
        "QDZ1 QBZ1 QCZ1 QEZ1 QDZ2 QBZ2 QEZ2 QHZ1 QHZ2 QDZ6 QDZ7 QBZ9 QBZ10 QBZ3 QEZ3 QEZ4 "
        "PPZ1 QDZ3 QDZ4 QBZ4 QBZ5 QHZ3 QHZ4 QDZ8 QDZ9 QDZ10 QDZ11 QEZ5 PPZ2")),
    StageDef("Fx", "Fx", "N", "drag", _names("RBX1 RBX2 RCX1 REX1 REX2 RHX1 RBX3")),
    StageDef("Fy", "Fy", "N", "kappa_slip", _names(
        "RBY1 RBY2 RCY1 REY1 REY2 RHY1 RHY2 RBY3 RVY1 RVY2 RVY4 RVY5 RVY6 RBY4 RVY3")),
    StageDef("Mz", "Mz", "N m", "any_kappa", _names("SSZ1 SSZ2 SSZ3 SSZ4")),
    # Mx on the runs that roll freely: its MF equation reads Fz, gamma and Fy, no Fx. On a
    # real drive/brake run the measured Mx follows Fx at zero slip angle and camber, and the
    # run carries a zero of its own (its Mx at zero forces is not the cornering run's); fitted
    # on every point, the stage spends its coefficients on a coupling and an offset it cannot
    # represent and misses the cornering and camber runs' Mx, which it can. A session of
    # drive/brake runs only is fitted on all of them.
    StageDef("Mx", "Mx", "N m", "rolling_runs", _names(
        "QSX1 QSX2 QSX3 QSX12 QSX13 QSX14 PPMX1 QSX4 QSX5 QSX6 QSX7 QSX8 QSX9 QSX10 QSX11")),
    StageDef("My", "My", "N m", "all", _names("QSY1 QSY2 QSY3 QSY4 QSY5 QSY6 QSY7 QSY8")),
)}

EVEN_START = {"Q_FCY": 0.1}
"""[-] Start of a coefficient whose effect is even in its value, when a stage frees it at 0.
The load law's side-force term -(Q_FCY Fy/Fz0)^2 has no gradient in Q_FCY at 0: the screen
would hold it there ("no effect") and a solver could not move it, and the stiffness, PFZ1 and
Q_FZ2 would absorb its effect (the golden test tyre's Q_FCY = 0.2 lowers the load at a
deflection by 4 % at Fy = Fz0, an effect the load law's other terms can only distort
themselves to mimic). At 0.1 it reduces the load by 1 % at Fy = Fz0; the fit takes
it from there, down to ~0 for a tyre without the term, where identify.fit.mf.minima.even_effect
holds it at 0 (its square not significant). The sign is immaterial (the fitted value is reported as
|Q_FCY|). Q_FCX, the same for the
longitudinal force, is not fitted: the vertical stage's free-rolling points have no Fx."""

DEFAULT_STAGES = ("Fx0", "Fy0", "Mz0", "Fx", "Fy", "Mz", "Mx", "My", "vertical", "geometry")
"""The stages in fit order. The vertical and geometry stages come last: no force or moment
stage reads their coefficients (useMode 211 takes kappa as given), while the loaded radius
reads the model's forces (Q_FCX, Q_FCY), which are then the fitted ones, not the start .tir's."""

_NEEDS_TEXT = """
VERTICAL_STIFFNESS load:0; PFZ1 pressure; Q_FZ2 load2:0; Q_V2 speed;
Q_V1 speed; DREFF load:0; FREFF load2:0; BREFF load2:0;
PDX2 load; PDX3 camber:2; PEX2 load; PEX3 load2:2; PEX4 kappa_sign; PKX2 load; PKX3 load3;
PHX2 load; PVX2 load; PPX1 pressure; PPX2 pressure2:2; PPX3 pressure; PPX4 pressure2:2;
PDY2 load; PDY3 camber:2; PEY2 load; PEY3 alpha_sign; PEY4 camber alpha_sign; PEY5 camber:2;
PKY2 load:0; PKY3 camber; PKY4 load2:0; PKY5 camber:2; PKY6 camber; PKY7 camber load;
PHY2 load; PVY2 load; PVY3 camber; PVY4 camber load; PPY1 pressure; PPY2 pressure;
PPY3 pressure; PPY4 pressure2:2; PPY5 pressure camber;
QBZ2 load; QBZ3 load2:2; QBZ4 camber; QBZ5 camber; QDZ2 load; QDZ3 camber; QDZ4 camber:2;
QDZ7 load; QDZ8 camber; QDZ9 camber load; QDZ10 camber:2; QDZ11 camber:2 load; QEZ2 load;
QEZ3 load2:2; QEZ5 camber; QHZ2 load; QHZ3 camber; QHZ4 camber load; PPZ1 pressure;
PPZ2 pressure camber;
RBX3 camber:2; REX2 load; RBY3 alpha_sign; RBY4 camber:2; REY2 load; RHY2 load; RVY2 load;
RVY3 camber;
SSZ3 camber; SSZ4 camber load;
QSX2 camber; QSX7 camber; QSX10 camber; QSX11 camber; QSX12 camber:2; QSX14 camber;
PPMX1 pressure camber;
QSY3 speed; QSY4 speed2; QSY5 camber:2; QSY6 camber:2 load:0; QSY7 load; QSY8 pressure
"""
_NEEDS_ITEMS = [item.split() for item in _NEEDS_TEXT.replace("\n", " ").split(";")
                if item.strip()]
NEEDS: dict[str, tuple[str, ...]] = {
    item[0]: tuple(t.split(":")[0] for t in item[1:]) for item in _NEEDS_ITEMS}
"""Coverage a coefficient needs: ``load``/``load2``/``load3`` >= 2/3/4 load levels (PKX3: with
three loads Kx/Fz = (PKX1 + PKX2 dfz) exp(PKX3 dfz) takes its three values on two branches, PKX2
= +-a, and a local solve from near one branch can end on the other), ``pressure``/``pressure2``
>= 2/3 pressures, ``speed``/``speed2`` >= 2/3 speeds, ``camber`` a camber variation,
``kappa_sign``/``alpha_sign`` slip of both signs (RBY3, a shift of the slip angle in By_kappa =
(RBY1 + RBY4 gamma^2) cos(atan(RBY2 (alpha - RBY3))), needs combined slip at slip angles of both
signs: at one sign, as on a TTC drive/brake run's 0, -3, -6 deg, it trades with RBY2 along a
ridge that only camber bends, so a fitted RBY3 is an extrapolation: a written RBY3 of -0.04
makes By_kappa 28 % smaller at +6 deg than at -6 deg on the side no point measured).
Geometry: R0 Q_RE0 - Re is (Fz0/Cz') (DREFF atan(BREFF x) + FREFF x) at the data's loads
x = Fz/Fz0, so at one pressure n load levels determine Q_RE0 and n - 1 of DREFF, FREFF, BREFF
(in that order); with three loads BREFF is separable from Q_RE0 only through the pressure
scaling of that term by the held Cz' = VERTICAL_STIFFNESS (1 + PFZ1 dpi), i.e. at two or more
pressures with PFZ1 != 0 (the sensitivity screen holds it otherwise, and the value then rests
on the CFz relation's PFZ1); Q_V1 needs free rolling at two speeds (omega^2 term)."""
ZERO_SLIP = frozenset(
    "PHY1 PHY2 PVY1 PVY2 PKY6 PKY7 QDZ6 QDZ7 QDZ8 QDZ9 QDZ10 QDZ11 PPZ2".split())
"""Coefficients of the pure lateral stages that a point at zero slip angle measures: the
offsets of Fy0 (SHy, SVy at zero camber), its camber stiffness (at zero slip angle a cambered
tyre's side force is Kyg0 gamma: PKY6, PKY7) and the residual torque of Mz0 (Dr, with its
camber and pressure terms). Their coverage (:data:`NEEDS`) counts every point of the stage.
The other coefficients of Fy0 and Mz0 shape the characteristic along the slip angle
(stiffness, peak, curvature, trail; the camber shift of the trail QHZ3, QHZ4 and of SVy,
PVY3, PVY4, which trade with PKY6, PKY7 at zero slip): their loads, pressures and cambers are
counted on the swept points only (identify.fit.mf.stage_data.coverage_missing). A real
drive/brake run stepped in camber puts zero-slip points at cambers, loads and pressures the
cornering sweeps may not hold; counted for a trail or stiffness term they freed it with no
sweep to fit it to, and the fitted trail followed the scatter of a few zero-slip points."""
TERM_VARIABLES = {"camber": "gamma", "load": "dfz", "load2": "dfz", "load3": "dfz",
                  "pressure": "dpi", "pressure2": "dpi"}
"""The variable of a need that the coefficient's term multiplies: |gamma| [rad], |dfz| [-],
|dpi| [-] (speed terms and slip signs are not small: none)."""


def _terms(item: list[str]) -> dict[str, int]:
    """variable -> power of one NEEDS item (name and its ``need[:k]`` tokens)."""
    powers: dict[str, int] = {}
    for token in item[1:]:
        need, _, k = token.partition(":")
        power = int(k or 1)
        if need in TERM_VARIABLES and power:
            var = TERM_VARIABLES[need]
            powers[var] = powers.get(var, 0) + power
    return powers


TERMS: dict[str, dict[str, int]] = {
    item[0]: _terms(item) for item in _NEEDS_ITEMS if _terms(item)}
"""The monomial a coefficient multiplies in the model equations, variable -> power (the same
text as NEEDS: ``need:k`` is the need's variable to the power k, k = 1 when not written; e.g.
PEY5 gamma^2 in Ey, QDZ11 dfz |gamma| gamma, PPY5 dpi gamma; PKY2 and PKY4 need loads but
multiply none); a coefficient not listed is zero-order. The identifiability screen scales a
coefficient's plausible change with it (identify.fit.mf.screen.term_magnitudes)."""

Values = Mapping[str, float]
Model = Callable[[Values], np.ndarray]


def subset_state(s: OperatingState, idx: np.ndarray) -> OperatingState:
    """The operating points ``idx`` of ``s``."""
    return dataclasses.replace(s, **{
        f.name: getattr(s, f.name)[idx] for f in dataclasses.fields(s)
        if isinstance(getattr(s, f.name), np.ndarray)})


def _combined_fx(P: Values, s: OperatingState) -> np.ndarray:
    """The combined-slip longitudinal force Fx = Gx_alpha Fx0 [N] at ``P``."""
    return longitudinal.gx_alpha(P, s) * longitudinal.fx0(P, s).fx0


def stage_inputs(stage: str, base: Values, s: OperatingState,
                 omega: np.ndarray | None = None) -> dict[str, object]:
    """What ``stage``'s prediction needs besides its own coefficients, computed once from the
    carried-forward values ``base`` at the points ``s`` (numpy).

    Returns
    -------
    dict
        Arrays [unit of each] and model pieces (PureLateral, CombinedLateral) by name; see
        :func:`stage_predict`.

    Raises
    ------
    ValueError
        An unknown stage, or the geometry or vertical stage without ``omega``.
    """
    if stage in ("geometry", "vertical"):
        if omega is None:
            raise ValueError(f"the {stage} stage needs the measured wheel speed omega")
        # exactly what evaluate(..., omega=omega) does: Re(omega + eps) (docs/model.md, 10.1)
        omega = np.asarray(omega, dtype=float) + np.finfo(float).eps
        if stage == "geometry":
            return {"omega": omega}
        # the loaded radius reads the model's forces (the load law's terms Q_FCX Fx, Q_FCY
        # Fy); no coefficient of this stage acts on them, so they are computed once at
        # ``base``
        return {"omega": omega, "fx": _combined_fx(base, s),
                "fy": lateral.fy_combined(base, s, lateral.fy0(base, s)).fy}
    if stage == "Fx0":
        return {"gxa": longitudinal.gx_alpha(base, s)}
    if stage == "Fx":
        return {"fx0": longitudinal.fx0(base, s).fx0}
    if stage == "Fy0":
        return {}
    # each stage computes only the forces it uses (Mx no longitudinal, My no lateral one), so
    # that it reads only the coefficients it depends on (identify.fit.mf.uncertainty)
    if stage == "My":
        return {"fx": _combined_fx(base, s)}
    pure = lateral.fy0(base, s)
    if stage == "Fy":
        return {"pure": pure}
    fy = lateral.fy_combined(base, s, pure)
    if stage == "Mx":
        return {"fy": fy.fy}
    if stage in ("Mz0", "Mz"):
        lon = longitudinal.fx0(base, s)
        fx = longitudinal.gx_alpha(base, s) * lon.fx0
        return {"pure": pure, "pure0": lateral.fy0(base, s, zero_camber=True), "fy": fy,
                "fx": fx, "kxk": lon.kxk}
    raise ValueError(f"unknown MF stage {stage!r}")


def stage_predict(stage: str, P: Values, s: OperatingState, inputs: Mapping[str, object],
                  xp=np, pure_slip: bool = False) -> np.ndarray:
    """The prediction of ``stage``'s quantity at the points ``s`` [N, N m or m].

    Parameters
    ----------
    stage : str
    P : mapping
        Every .tir value (the stage's own coefficients as fitted).
    s : OperatingState
        The points, prepared with useMode 211.
    inputs : mapping
        :func:`stage_inputs` of the same points.
    xp : module
        The array module of the equations: numpy, or jax.numpy for exact derivatives
        (identify.fit.mf.jacobian). The Fy0 stage evaluates its combined-slip expression on
        the points with kappa != 0 only under numpy (``inputs["slip"]``, see
        :func:`stage_model`) and selects it with ``where`` otherwise; at kappa == 0 both give
        Fy0 exactly.
    pure_slip : bool
        Fy0 under JAX: the caller knows every point is at kappa == 0, where the prediction is
        Fy0 alone; the combined-slip expression is not traced, and its forward-mode derivatives
        are not paid for.
    """
    if stage == "geometry":
        return vertical._effective_radius(P, s, inputs["omega"], xp)
    if stage == "vertical":  # numpy only (the MF 6.2 solve iterates; no exact Jacobian)
        deflection = (vertical.deflection_62 if int(P["FITTYP"]) == 62
                      else vertical.deflection_61)
        return deflection(P, s, inputs["fx"], inputs["fy"], inputs["omega"]).rl
    if stage == "Fx0":
        return inputs["gxa"] * longitudinal.fx0(P, s, xp).fx0
    if stage == "Fx":
        return longitudinal.gx_alpha(P, s, xp) * inputs["fx0"]
    if stage == "Fy0":
        # at kappa == 0 exactly Gyk = 1 and SVyk = 0, so Fy equals Fy0 (docs/model.md,
        # section 6); the combined expression is evaluated only where kappa != 0
        pure = lateral.fy0(P, s, xp=xp)
        fy = pure.fy0
        if xp is not np and pure_slip:
            return fy
        if xp is not np:  # one pure-slip evaluation for both (traced once)
            return xp.where(s.kappa != 0, lateral.fy_combined(P, s, pure, xp).fy, fy)
        slip, s_slip = inputs["slip"], inputs["s_slip"]
        if slip.size:
            fy = np.array(fy, copy=True)
            fy[..., slip] = lateral.fy_combined(P, s_slip, lateral.fy0(P, s_slip)).fy
        return fy
    if stage == "Fy":
        return lateral.fy_combined(P, s, inputs["pure"], xp).fy
    if stage in ("Mz0", "Mz"):
        return aligning.mz(P, s, inputs["pure"], inputs["pure0"], inputs["fy"], inputs["fx"],
                           inputs["kxk"], xp, slip=inputs.get("mz_slip")).mz
    if stage == "Mx":
        return moments.mx(P, s, inputs["fy"], xp)
    if stage == "My":
        return moments.my(P, s, inputs["fx"], xp)
    raise ValueError(f"unknown MF stage {stage!r}")


def stage_model(stage: str, base: Values, s: OperatingState,
                omega: np.ndarray | None = None) -> Model:
    """The vectorised model of ``stage`` at the operating points ``s`` (numpy).

    Parameters
    ----------
    stage : str
        Stage name.
    base : mapping
        Every .tir value; the stage's own coefficients are overridden per call.
    s : OperatingState
        The stage's points, prepared with useMode 211.
    omega : ndarray [rad/s], optional
        The measured wheel speed at the points (stages ``geometry`` and ``vertical`` only,
        required there).

    Returns
    -------
    callable
        values -> prediction of the stage's quantity at every point [N or N m]. ``values`` may
        hold floats or arrays of shape (walkers, 1) (then the result is (walkers, points)).
    """
    inputs = _model_inputs(stage, base, s, omega)

    def model(values: Values) -> np.ndarray:
        return stage_predict(stage, {**base, **values}, s, inputs)
    return model


def _model_inputs(stage: str, base: Values, s: OperatingState,
                  omega: np.ndarray | None) -> dict[str, object]:
    """:func:`stage_inputs`, for Fy0 the points with kappa != 0 (see stage_predict), for Mz0
    and Mz the residual moment's slip (identify.model.aligning.residual_slip)."""
    inputs = stage_inputs(stage, base, s, omega)
    if stage == "Fy0":
        slip = np.flatnonzero(s.kappa != 0)
        inputs = {"slip": slip, "s_slip": subset_state(s, slip)}
    if stage in ("Mz0", "Mz"):  # the residual moment's slip reads no coefficient of these
        inputs = {**inputs, "mz_slip": aligning.residual_slip(s, inputs["pure"], inputs["kxk"])}
    return inputs


class _Reads(dict):
    """A parameter mapping that records the names read from it (``names_read``)."""

    def __init__(self, *args):
        super().__init__(*args)
        self.names_read: set[str] = set()

    def __getitem__(self, key):
        self.names_read.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.names_read.add(key)
        return super().get(key, default)


def names_read(stage: str, values: Values, s: OperatingState,
               omega: np.ndarray | None = None) -> set[str]:
    """The parameter names that the prediction of ``stage`` at ``values`` (every .tir value)
    reads, its inputs' equations included. The prediction cannot depend on any other name:
    changing one leaves the same arithmetic on the same numbers."""
    P = _Reads(values)
    stage_predict(stage, P, s, _model_inputs(stage, P, s, omega))
    return P.names_read
