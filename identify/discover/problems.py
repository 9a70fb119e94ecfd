"""The discovery problems of a measurement folder, with the base model applied.

Relation problems come from the characteristic tables (the folder's own, and the extraction of
raw Flatplank runs when ``identify.extract`` is available) through the builders of
:mod:`identify.fit.relations.problems`; MF stage problems come from the trailer sweeps
(:mod:`identify.discover.stage_problems`). Every problem is named (``CFy``, ``RR``, ``MF/Fy``,
``camber/Fy_gamma``, ``sidewall/x`` ...) for the library's ``relations`` patterns.

The base model (:class:`Base`) decides which library coefficients are candidates:

- ``simplest``: every library coefficient at its neutral value;
- ``tir``: the coefficients that are neutral in the given .tir; the others are fitted;
- ``form``: a named base form's coefficients; the other library coefficients are fitted.
"""
from __future__ import annotations

import dataclasses
import fnmatch
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import lmfit
import numpy as np
import pandas as pd

from identify.discover.library import BaseForm, Library
from identify.discover.objective import problem_name
from identify.discover.stage_problems import label_sweeps, stage_problem
from identify.fit.relations import problems as R
from identify.fit.solve.problem import FitProblem

__all__ = ["Base", "base_values", "apply_base", "relation_problems", "trailer_problems",
           "cmz_problem", "select", "COMPANIONS"]

#: Coefficients freed together with a camber relation (its own camber stiffness terms).
COMPANIONS: dict[str, tuple[str, ...]] = {"camber/Fy_gamma": ("PKY6", "PKY7"),
                                          "camber/Mz_gamma": ("QDZ8", "QDZ9"),
                                          "camber/Mx_gamma": ("QSX2",)}


@dataclass(frozen=True)
class Base:
    """The base model.

    Attributes
    ----------
    kind : str              ``"simplest"``, ``"tir"`` or ``"form"``
    name : str              .tir path or form name ("" for simplest)
    form : BaseForm or None
    """

    kind: str = "simplest"
    name: str = ""
    form: BaseForm | None = None

    def neutral(self, key: str, tir: Mapping[str, float], neutral: float) -> bool:
        """Is library coefficient ``key`` held at its neutral value (a candidate)?"""
        if self.kind == "simplest":
            return True
        if self.kind == "form":
            return key in self.form.neutral
        return abs(float(tir.get(key, neutral)) - neutral) <= 1e-12

    def to_dict(self) -> dict:
        return {"kind": self.kind, "name": self.name,
                "neutral": list(self.form.neutral) if self.form else None}


def base_values(tir: Mapping[str, float], base: Base, library: Library) -> dict[str, float]:
    """The .tir with the base's candidate coefficients set to their neutral values."""
    out = dict(tir)
    for key, neutral in library.neutral_values().items():
        if base.neutral(key, tir, neutral):
            out[key] = neutral
    return out


def apply_base(problem: FitProblem, base: Base, library: Library,
               tir: Mapping[str, float]) -> FitProblem:
    """Hold the base's candidate coefficients at neutral, fit the other library coefficients."""
    P = problem.parameters.copy()
    bounds = {k: b for c in library.candidates for k, b in c.bounds.items()}
    for key, neutral in library.neutral_values().items():
        if key not in P:
            continue
        if base.neutral(key, tir, neutral):
            P[key].set(value=neutral, vary=False)
        elif not P[key].vary:
            lo, hi = bounds[key]
            start = float(np.clip(tir.get(key, P[key].value), lo, hi))
            P[key].set(value=start, vary=True, min=lo, max=hi)
    return dataclasses.replace(problem, parameters=P)


def _named(problem: FitProblem | None, name: str, **extra) -> FitProblem | None:
    if problem is None:
        return None
    return dataclasses.replace(problem, extra={**problem.extra, "name": name, **extra})


def cmz_problem(chars: pd.DataFrame, ctx: R.Context) -> FitProblem | None:
    """Yaw stiffness with T1 nested in T2: CMz = YAW_STIFFNESS (r + PCMZ2 r^2)(1 + PCMZ1 dpi),
    r = Fz/Fz0 (T1 at PCMZ2 = 0; in the .tir's T2 form PCMZ1' = 1, PCMZ2, PCMZ3 = PCMZ1)."""
    d = chars[chars["quantity"] == "CMz"].reset_index(drop=True)
    if d.empty:
        return None
    fz, pi = d["Fz_N"].to_numpy(float), d["pi_bar"].to_numpy(float)
    r, dp = fz / ctx.fz0, ctx.dp(pi)
    slope = float(np.median(d["value"] / r))
    P = lmfit.Parameters()
    P.add("YAW_STIFFNESS", value=slope, min=0.0, max=20 * abs(slope) + 1.0)
    P.add("PCMZ1", value=float(ctx.tir.get("PCMZ1", -0.3)), min=-1.0, max=1.0)
    P.add("PCMZ2", value=0.0, min=-0.4, max=1.0)

    def model(v):
        return v["YAW_STIFFNESS"] * (r + v["PCMZ2"] * r ** 2) * (1 + v["PCMZ1"] * dp)
    return FitProblem("CMz", "T1_T2", P, model, d["value"], pi, unit="N*m/rad",
                      extra={"name": "CMz", "quantity": "CMz", "Fz_N": fz})


def _with_companions(problem: FitProblem | None, name: str, tir) -> FitProblem | None:
    if problem is None:
        return None
    P = problem.parameters.copy()
    for k in COMPANIONS.get(name, ()):
        v = float(tir.get(k, 0.0))
        span = max(abs(v), 0.1)
        P.add(k, value=v, vary=True, min=v - 10 * span, max=v + 10 * span)
    return dataclasses.replace(problem, parameters=P)


def _on(ctx: R.Context, values: Mapping[str, float]) -> R.Context:
    """``ctx`` with its .tir updated by ``values`` (a rebuild from the model state)."""
    return dataclasses.replace(ctx, tir={**ctx.tir, **values})


def relation_problems(chars: pd.DataFrame, ctx: R.Context) -> list[FitProblem]:
    """Every relation problem whose characteristics are present, in model-state order (the
    relaxation lengths after the locked-hub CFy whose coefficients they read). Problems whose
    model reads the whole .tir (rolling resistance, camber) carry ``extra["rebuild"]``."""
    t = ctx.tir
    builders: list[tuple[str, Callable, Callable | None]] = [
        ("CFz", lambda: R.cfz(chars, ctx, "mf"), None),
        ("CFx", lambda: R.cfx(chars, ctx, "linear_load"), None),
        ("CFy", lambda: R.cfy(chars, ctx, "linear_load"), None),
        ("CFy/relaxation", lambda: R.cfy(chars, ctx, "relaxation"), None),
        ("CMz", lambda: cmz_problem(chars, ctx), None),
        ("RR", lambda: R.rolling_resistance(chars, ctx, "old"),
         lambda v: R.rolling_resistance(chars, _on(ctx, v), "old")),  # Fx at free rolling
    ]
    for q in ("Fy_gamma", "Mz_gamma", "Mx_gamma"):
        builders.append((f"camber/{q}", lambda q=q: _with_companions(
            R.camber(chars, ctx, q), f"camber/{q}", t),
            lambda v, q=q: R.camber(chars, _on(ctx, v), q)))
    for mode in ("x", "y", "z", "theta", "gamma", "psi"):
        builders.append((f"sidewall/{mode}", lambda m=mode: R.sidewall(chars, ctx, m), None))
    out = []
    for name, build, rebuild in builders:
        if "quantity" not in chars or chars.empty:
            break
        deps = {"depends_on": ("MF/Fx",)} if name == "RR" else {}
        problem = _named(build(), name, **({"rebuild": rebuild, **deps} if rebuild else {}))
        if problem is not None:
            out.append(problem)
    return out


def _rr_from_sweeps(frame: pd.DataFrame, ctx: R.Context) -> FitProblem | None:
    d = frame[frame["kind"] == "rolling_resistance"].reset_index(drop=True)
    if d.empty or d["My"].isna().all():
        return None
    chars = pd.DataFrame({"quantity": "FxRR", "pi_bar": d["p"] / 1e5, "p_Pa": d["p"],
                          "Fz_N": d["Fz"], "Vx_mps": d["Vx"], "value": d["My"] / ctx.r0})
    problem = R.rolling_resistance(chars, ctx, "old")
    return _named(dataclasses.replace(problem, sweeps=d["sweep"].to_numpy()), "RR",
                  noise_group=d["run"].astype(str).to_numpy(),
                  rebuild=lambda v: R.rolling_resistance(chars, _on(ctx, v), "old"),
                  depends_on=("MF/Fx",))


#: The MF stages whose coefficients each stage's model reads (Mx and Mz: the lateral force).
STAGE_INPUTS = {"Fx": (), "Fy": (), "Mx": ("MF/Fy",), "Mz": ("MF/Fx", "MF/Fy")}


def trailer_problems(trailer: pd.DataFrame, tir: dict, ctx: R.Context,
                     tests: Mapping[str, str] | None = None, *, with_rr: bool = True
                     ) -> list[FitProblem]:
    """MF stage problems (and rolling resistance) of the trailer sweeps, in model-state order
    (Fx, Fy, then Mx and Mz, which use the lateral force of the Fy stage). Each carries
    ``extra["rebuild"]``: discovery rebuilds Mx and Mz from the fitted Fy coefficients
    (:mod:`identify.discover.state`) instead of a separate pre-fit here; and
    ``extra["at_pressure"]``: the same problem with every point at one pressure
    (:mod:`identify.discover.pressure_shape`)."""
    if trailer is None or trailer.empty:
        return []
    frame = label_sweeps(trailer, tests)
    base = dict(tir)
    out = []
    for name in ("Fx", "Fy", "Mx", "Mz"):
        p = stage_problem(name, frame, base)
        if p is not None:
            p0 = float(base.get("NOMPRES", 0.0) or 0.0)
            at_pressure = (None if not p0 > 0 else lambda v, dpi, name=name, p0=p0: stage_problem(
                name, frame.assign(p=p0 * (1.0 + dpi)), {**base, **v}))
            out.append(_named(p, f"MF/{name}", rebuild=lambda v, name=name: stage_problem(
                name, frame, {**base, **v}), depends_on=STAGE_INPUTS[name],
                at_pressure=at_pressure))
    if with_rr:
        rr = _rr_from_sweeps(frame, ctx)
        if rr is not None:
            out.append(rr)
    return out


def select(problems: list[FitProblem], patterns: tuple[str, ...]) -> list[FitProblem]:
    """Problems whose names match any pattern (all when ``patterns`` is empty)."""
    if not patterns:
        return problems
    return [p for p in problems if any(fnmatch.fnmatchcase(problem_name(p), pat)
                                       or problem_name(p).startswith(pat.rstrip("/") + "/")
                                       for pat in patterns)]

