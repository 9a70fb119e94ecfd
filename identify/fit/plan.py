"""Which relations and forms a folder's fit runs, and which result feeds each .tir key.

One table, as data: (relation, form, builder, keys written to the .tir when this form is the
one the .tir takes). The pipeline runs every entry whose data are present; ``--only NAME``
selects relations by name.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Callable

from identify.fit import relations as R


@dataclass(frozen=True)
class PlanEntry:
    """One fit of the plan.

    Attributes
    ----------
    relation, form : str
    build : callable          (characteristics, Context) -> FitProblem | None
    writes : tuple of str     .tir keys this form supplies when it is the chosen form
    """

    relation: str
    form: str
    build: Callable
    writes: tuple[str, ...] = ()


def _sidewall_entries() -> list[PlanEntry]:
    out = []
    for mode in ("x", "y", "z", "theta", "gamma", "psi"):
        out.append(PlanEntry("sidewall", f"scaling_{mode}",
                             partial(R.sidewall, mode=mode, form="scaling"),
                             (f"F_{mode.upper()}",)))
        out.append(PlanEntry("sidewall", f"rotta_{mode}",
                             partial(R.sidewall, mode=mode, form="rotta")))
    return out


PLAN: tuple[PlanEntry, ...] = (
    PlanEntry("CFz", "mf", partial(R.cfz, form="mf"), ("VERTICAL_STIFFNESS", "Q_FZ2", "PFZ1")),
    PlanEntry("CFz", "qfz", partial(R.cfz, form="qfz")),
    PlanEntry("CFx", "linear_load", partial(R.cfx, form="linear_load"),
              ("LONGITUDINAL_STIFFNESS", "PCFX1", "PCFX2", "PCFX3")),
    PlanEntry("CFx", "quadratic_load", partial(R.cfx, form="quadratic_load")),
    PlanEntry("CFy", "linear_load", partial(R.cfy, form="linear_load"),
              ("LATERAL_STIFFNESS", "PCFY1", "PCFY2", "PCFY3")),
    PlanEntry("CFy", "quadratic_load", partial(R.cfy, form="quadratic_load")),
    PlanEntry("CFy", "relaxation", partial(R.cfy, form="relaxation")),
    PlanEntry("CMz", "T1", partial(R.cmz, form="T1"), ("YAW_STIFFNESS", "PCMZ1")),
    PlanEntry("CMz", "T2", partial(R.cmz, form="T2")),
    PlanEntry("RR", "new", partial(R.rolling_resistance, form="new"),
              ("QSY1", "QSY3", "QSY4", "QSY7", "QSY8")),
    PlanEntry("RR", "old", partial(R.rolling_resistance, form="old")),
    PlanEntry("camber", "Fy_gamma", partial(R.camber, quantity="Fy_gamma"), ("PPY5",)),
    PlanEntry("camber", "Mz_gamma", partial(R.camber, quantity="Mz_gamma"), ("PPZ2",)),
    PlanEntry("camber", "Mx_gamma", partial(R.camber, quantity="Mx_gamma"), ("PPMX1",)),
    *_sidewall_entries(),
)

RELATION_NAMES = tuple(dict.fromkeys(e.relation for e in PLAN)) + ("MF",)
