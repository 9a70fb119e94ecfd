"""One model state across the problems of a discovery run: every key has exactly one source.

Several problems can hold the same coefficient: the lateral stiffness LATERAL_STIFFNESS,
PCFY1-3 in the locked-hub problem ``CFy`` and in the relaxation-length problem
``CFy/relaxation``; the Fy coefficients in ``MF/Fy`` and, through the lateral force they feed,
in ``MF/Mx`` and ``MF/Mz``. If each fitted them on its own, the .tir would hold whichever was
written last. Here the problems come in an order (upstream first) and

- a key is **owned** by the first problem that fits it or tests it as a candidate;
- every later problem that holds the key **reads** it: the key is fixed there at the owner's
  current value (and problems whose model reads the whole .tir, ``extra["rebuild"]``, are
  rebuilt from the state);
- when an owner changes (an accepted effect, a refit), the problems downstream of it are
  re-bound and refitted, in order, so that their own coefficients are fitted against the
  owner's final ones.

The state at the end (:attr:`ModelState.values`, with :attr:`ModelState.sources`) is what the
.tir gets: each key from its owner's final fit, equal to what every problem used.

``extra["rebuild"]`` of a problem is a callable ``values -> FitProblem`` that builds the same
problem (same data) with the given .tir values; only its model and Jacobian are taken.
``extra["depends_on"]`` (glob patterns of problem names) narrows what a rebuilt model reads
(``MF/Mx`` reads ``MF/Fy``); without it, a rebuilt problem depends on every earlier owner.
"""
from __future__ import annotations

import dataclasses
import fnmatch
from dataclasses import dataclass, field

import numpy as np

from identify.discover.drift import DRIFT_KEY, drifting
from identify.discover.library import Library
from identify.discover.objective import problem_name
from identify.fit.solve.problem import FitProblem

__all__ = ["ModelState", "claims"]


def claims(problem: FitProblem, library: Library) -> set[str]:
    """Keys a problem fits or tests: its free parameters and the coefficients of the library
    candidates that apply to it (present at their neutral values, or injectable where the
    model reads the whole .tir)."""
    name = problem_name(problem)
    out = set(problem.free)
    P = problem.parameters
    full = bool(problem.extra.get("full_tir"))
    for cand in library.for_problem(name):
        if cand.nuisance:
            continue  # a property of the measurement: local to the problem
        if all((k in P and not P[k].vary and abs(P[k].value - v) <= 1e-12)
               or (k not in P and full) for k, v in cand.coefficients.items()):
            out.update(cand.coefficients)
    return out


@dataclass
class ModelState:
    """Owners, readers and current values of every key (module doc).

    Attributes
    ----------
    order : list of str          problem names, upstream first
    owner : dict                 key -> owning problem name
    values : dict                key -> current value (owned keys)
    """

    order: list[str]
    owner: dict[str, str] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)

    @classmethod
    def of(cls, problems: list[FitProblem], library: Library) -> ModelState:
        """Ownership from the problems' order; values from their starting parameters."""
        state = cls([problem_name(p) for p in problems])
        for p in problems:
            name = problem_name(p)
            for k in sorted(claims(p, library)):
                if k not in state.owner:
                    state.owner[k] = name
                    state.values[k] = float(p.parameters[k].value) if k in p.parameters \
                        else float(next(c.coefficients[k] for c in library.for_problem(name)
                                        if k in c.coefficients))
        return state

    @property
    def sources(self) -> dict[str, str]:
        """Key -> the problem it comes from."""
        return dict(self.owner)

    def owned(self, name: str) -> set[str]:
        return {k for k, o in self.owner.items() if o == name}

    def reads(self, problem: FitProblem) -> dict[str, float]:
        """The keys ``problem`` holds that another problem owns, at the owners' values."""
        name = problem_name(problem)
        return {k: self.values[k] for k in problem.parameters
                if k in self.owner and self.owner[k] != name}

    def upstream(self, name: str, problem: FitProblem) -> tuple[str, ...]:
        """The problems whose coefficients ``problem`` uses: the owners of the parameters it
        reads and, when its model is rebuilt from the state, every earlier owner."""
        out = {self.owner[k] for k in self.reads(problem)}
        if problem.extra.get("rebuild") is not None and name in self.order:
            earlier = self.order[:self.order.index(name)]
            pats = problem.extra.get("depends_on")
            out |= {o for o in self.owner.values() if o in earlier
                    and (pats is None or any(fnmatch.fnmatchcase(o, p) for p in pats))}
        return tuple(o for o in self.order if o in out)

    def depends(self, name: str, problem: FitProblem, changed: set[str]) -> bool:
        """Does ``problem`` (named ``name``) read anything the ``changed`` problems own?"""
        return bool(set(self.upstream(name, problem)) & changed)

    def bind(self, problem: FitProblem) -> FitProblem:
        """``problem`` with every key another problem owns fixed at the owner's value, and its
        model rebuilt from the state when it reads the whole .tir."""
        name = problem_name(problem)
        P = problem.parameters.copy()
        for k, v in self.reads(problem).items():
            P[k].set(value=v, vary=False, min=min(P[k].min, v), max=max(P[k].max, v))
        out = dataclasses.replace(problem, parameters=P)
        rebuild = problem.extra.get("rebuild")
        if rebuild is not None:
            fresh = rebuild({k: v for k, v in self.values.items() if self.owner[k] != name})
            model, jac = fresh.model, fresh.jacobian
            if DRIFT_KEY in P:  # the drift candidate scales the rebuilt model as before
                model, jac = drifting(model, jac, np.asarray(problem.extra["session_pos"],
                                                             dtype=float))
            out = dataclasses.replace(out, model=model, jacobian=jac)
        return out

    def update(self, name: str, values: dict[str, float]) -> None:
        """Take the owned keys' current values from problem ``name``'s parameter values."""
        for k, v in values.items():
            if self.owner.get(k) == name and np.isfinite(v):
                self.values[k] = float(v)
