"""Which relations and forms a folder's fit runs, and which result feeds each .tir key.

One table, as data: (relation, form, builder, keys written to the .tir when this form is the
one the .tir takes, constants the form implies). The pipeline runs every entry whose data are
present; ``--only NAME`` selects relations by name. A relation with a nested pair of forms
(:data:`identify.fit.relations.forms.NESTED_FORMS`: CFx, CFy linear or quadratic in load, CMz T1 or
T2,
RR old or new) writes the form the data choose (:func:`identify.fit.relations.forms.choose_form`);
every other relation writes the one form that has ``writes``.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial

from identify.fit.relations import problems as R


@dataclass(frozen=True)
class PlanEntry:
    """One fit of the plan.

    Attributes
    ----------
    relation, form : str
    build : callable          (characteristics, Context) -> FitProblem | None
    writes : tuple of str     .tir keys this form supplies when it is the chosen form (from
                              the fit's parameters, free or held at the form's neutral value)
    constants : mapping       further .tir values the form implies (CMZ_FORM ...)
    quantity : str            the characteristic it is fitted to (for the form choice)
    """

    relation: str
    form: str
    build: Callable
    writes: tuple[str, ...] = ()
    constants: Mapping[str, float] = field(default_factory=dict)
    quantity: str = ""


def _sidewall_entries() -> list[PlanEntry]:
    out = []
    for mode in ("x", "y", "z", "theta", "gamma", "psi"):
        out.append(PlanEntry("sidewall", f"scaling_{mode}",
                             partial(R.sidewall, mode=mode, form="scaling"),
                             (f"F_{mode.upper()}",), quantity="f_nat"))
        out.append(PlanEntry("sidewall", f"rotta_{mode}",
                             partial(R.sidewall, mode=mode, form="rotta"), quantity="f_nat"))
    return out


_CFX = ("LONGITUDINAL_STIFFNESS", "PCFX1", "PCFX2", "PCFX3")
_CFY = ("LATERAL_STIFFNESS", "PCFY1", "PCFY2", "PCFY3")
_RR = ("QSY1", "QSY3", "QSY4", "QSY7", "QSY8")

PLAN: tuple[PlanEntry, ...] = (
    PlanEntry("CFz", "mf", partial(R.cfz, form="mf"), ("VERTICAL_STIFFNESS", "Q_FZ2", "PFZ1"),
              quantity="CFz"),
    PlanEntry("CFz", "qfz", partial(R.cfz, form="qfz"), quantity="CFz"),
    PlanEntry("CFx", "linear_load", partial(R.cfx, form="linear_load"), _CFX, quantity="CFx"),
    PlanEntry("CFx", "quadratic_load", partial(R.cfx, form="quadratic_load"), _CFX,
              quantity="CFx"),
    PlanEntry("CFy", "linear_load", partial(R.cfy, form="linear_load"), _CFY, quantity="CFy"),
    PlanEntry("CFy", "quadratic_load", partial(R.cfy, form="quadratic_load"), _CFY,
              quantity="CFy"),
    PlanEntry("CFy", "relaxation", partial(R.cfy, form="relaxation"), quantity="sigma_y"),
    PlanEntry("CMz", "T1", partial(R.cmz, form="T1"), ("YAW_STIFFNESS", "PCMZ1"),
              {"CMZ_FORM": 1.0, "PCMZ2": 0.0, "PCMZ3": 0.0}, quantity="CMz"),
    PlanEntry("CMz", "T2", partial(R.cmz, form="T2"),
              ("YAW_STIFFNESS", "PCMZ1", "PCMZ2", "PCMZ3"), {"CMZ_FORM": 2.0}, quantity="CMz"),
    PlanEntry("RR", "new", partial(R.rolling_resistance, form="new"), _RR, quantity="FxRR"),
    PlanEntry("RR", "old", partial(R.rolling_resistance, form="old"), _RR, quantity="FxRR"),
    PlanEntry("camber", "Fy_gamma", partial(R.camber, quantity="Fy_gamma"), ("PPY5",),
              quantity="Fy_gamma"),
    PlanEntry("camber", "Mz_gamma", partial(R.camber, quantity="Mz_gamma"), ("PPZ2",),
              quantity="Mz_gamma"),
    PlanEntry("camber", "Mx_gamma", partial(R.camber, quantity="Mx_gamma"), ("PPMX1",),
              quantity="Mx_gamma"),
    *_sidewall_entries(),
)

RELATION_NAMES = tuple(dict.fromkeys(e.relation for e in PLAN)) + ("MF",)


def entry(relation: str, form: str) -> PlanEntry:
    """The plan entry of ``relation``/``form``; KeyError when there is none."""
    for e in PLAN:
        if e.relation == relation and e.form == form:
            return e
    raise KeyError(f"{relation}/{form}")


def forms_of(relation: str) -> tuple[str, ...]:
    """The forms the plan fits for ``relation``."""
    return tuple(e.form for e in PLAN if e.relation == relation)
