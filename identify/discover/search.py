"""The forward-stepwise search: score -> add the best -> refit -> confirm -> repeat.

Per step, every candidate of every problem is scored from the current fit (projected LM test,
:mod:`identify.discover.score`); p-values are Holm-adjusted over all testable candidates; a
candidate passes when its adjusted p-value is below ``alpha`` and it is predicted to explain at
least ``min_explained`` of the excess error above the noise floor (when the base error is above
the floor estimate at all). The best passing candidate
(smallest p) is refitted and kept only when the likelihood-ratio/F test (cluster-robust Wald
under cluster-robust noise), at the same Holm level, AND the held-out error (folds from the
design, :mod:`identify.discover.design`) agree. When no single candidate is accepted, the blocks
they form are tried (:mod:`identify.discover.joint`). An accepted effect updates the one model
state and every problem downstream of it is refitted (:mod:`identify.discover.state`).
Candidates that cannot be told apart (|cos| > 0.95) are reported as an ambiguity group, never
as one confident name.
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from identify.core.progress import Progress
from identify.core.serial import Serial
from identify.discover.conclude import conclusion, summaries
from identify.discover.confirm import confirm
from identify.discover.final_accepted import final_accepted, headline, sign_note
from identify.discover.joint import try_blocks
from identify.discover.library import Candidate, Library
from identify.discover.objective import problem_name
from identify.discover.prepared_problem import Working, prepare, refresh, renoise
from identify.discover.pressure_shape import pressure_shapes
from identify.discover.result import Accepted, CandidateRow, Discovery, Step, excess_explained
from identify.discover.score import ambiguity_groups, canonical_cosines, holm, score_candidates
from identify.discover.state import ModelState
from identify.fit.solve.problem import FitProblem

__all__ = ["Settings", "discover"]


@dataclass(frozen=True)
class Settings(Serial):
    """Settings of a discovery run.

    Attributes
    ----------
    alpha : float            family-wise significance level (Holm) [-]
    max_steps : int          most effects added to one problem
    max_total : int          most steps in all
    min_explained : float    least predicted fraction of the excess error explained [-]
    n_starts : int           base-fit starts (> 1: multi-start global search)
    seed : int
    max_tries : int          candidates refitted per step before stopping
    heldout : str            held-out scheme: ``"auto"`` (from the design), ``"pressure"``
                             (leave one pressure out), ``"cells"`` (k-fold within condition
                             cells) or ``"rows"`` (interleaved points)
    joint : bool             test blocks of candidates that only generalise together
    """

    alpha: float = 0.05
    max_steps: int = 4
    max_total: int = 60
    min_explained: float = 0.10
    n_starts: int = 1
    seed: int = 0
    max_tries: int = 3
    heldout: str = "auto"
    joint: bool = True



def _score(w: Working) -> tuple[dict, dict, list]:
    """Scores, cosines and ambiguity groups of one problem's candidates."""
    t0 = time.process_time()
    vals = w.problem.values(w.x)
    cols = {c.name: w.objective.columns(w.x, {k: vals[k] for k in c.coefficients})
            for c in w.candidates}
    kind = w.noise.kind if w.noise.kind == "cluster" else "independent"
    scores, projected = score_candidates(w.sol.r, w.sol.jac, cols, kind=kind,
                                         clusters=w.objective.index,
                                         shapes=pressure_shapes(w, w.candidates))
    w.columns = cols  # for the joint blocks of this step
    testable = [n for n in scores if scores[n].testable]
    cos = canonical_cosines({n: projected[n] for n in testable})
    groups = ambiguity_groups(testable, cos)
    w.score_seconds = w.score_seconds or time.process_time() - t0
    return scores, cos, groups


def _rows(works: list[Working], settings: Settings) -> tuple[list, dict]:
    """The candidate table of a step and, per row, what confirmation needs."""
    scored = []
    for w in works:
        scores, cos, groups = _score(w)
        for c in w.candidates:
            scored.append((w, c, scores[c.name], cos, groups))
    pvals = {(w.name, c.name): s.p_value for w, c, s, _, _ in scored if s.testable}
    adj = holm(pvals)
    order = sorted(pvals, key=lambda key: pvals[key])
    factor = {key: len(order) - i for i, key in enumerate(order)}
    rows, info = [], {}
    for w, c, s, cos, groups in scored:
        key = (w.name, c.name)
        e0 = w.error_pct()
        floor = w.floor_pct if np.isfinite(w.floor_pct) else 0.0
        e1 = e0 * np.sqrt(max(1.0 - s.drop / w.sol.rss, 0.0)) if s.testable else e0
        excess = e0 ** 2 - floor ** 2
        # no excess above the floor estimate: the floor (from residuals that still hold the
        # missing effect) is not trusted to block; significance and held-out error decide
        explained = (e0 ** 2 - e1 ** 2) / excess if excess > 0 else float("inf")
        group = next((g for g in groups if c.name in g), ())
        passes = bool(s.testable and adj.get(key, 1.0) <= settings.alpha
                      and explained >= settings.min_explained)
        others = {b: v for (a, b), v in cos.items() if a == c.name}
        rows.append(CandidateRow(c.name, w.name, tuple(c.coefficients), c.equation,
                                 c.description, s.testable, s.rel_norm, s.statistic, s.dof,
                                 s.p_value, adj.get(key, 1.0), e1, explained, others,
                                 tuple(g for g in group if g != c.name), passes))
        info[key] = (w, c, s, factor.get(key, 1))
    return rows, info


def discover(problems: Sequence[FitProblem], library: Library,
             settings: Settings = Settings(), *, base: dict | None = None,
             progress: Progress | None = None) -> Discovery:
    """Find missing effects in ``problems`` (library coefficients held at neutral values).

    Parameters
    ----------
    problems : sequence of FitProblem
        The base models with their data, upstream first (:mod:`identify.discover.state`: a
        key shared by several problems belongs to the first that fits or tests it, the later
        ones read it); ``extra["name"]`` names a problem for the library's ``relations``
        patterns (default ``relation/form``).
    library : Library
    settings : Settings
    base : dict, optional
        Description of the base model for the output ({kind, name, tir}).
    progress : callable, optional
        Called with one line per phase (base fits, scoring, refits, updates), with times.
    """

    with threadpool_limits(limits=1):  # small dense problems: threads only add overhead
        return _discover(list(problems), library, settings, base, progress or _quiet)


def _quiet(_: str) -> None:
    return None


def _prepare_all(problems, library, settings, state: ModelState, say) -> tuple[list, list]:
    """Bind each problem to the state and fit its base model, upstream first."""
    works, notes = [], []
    for p in problems:
        name = problem_name(p)
        p = state.bind(p)
        cands = [c for c in library.for_problem(name)
                 if c.nuisance or all(state.owner.get(k) == name for k in c.coefficients)]
        if not p.free and not [c for c in cands if not c.nuisance]:
            src = sorted({state.owner[k] for k in state.reads(p)})
            notes.append(f"{name} not analysed: every coefficient it fits comes from "
                         f"{', '.join(src) or 'elsewhere'}")
            continue
        say(f"{name}: base fit and diagnosis ({p.measured.size} points, {len(p.free)} "
            "parameters)")
        w = prepare(p, library, n_starts=settings.n_starts, seed=settings.seed,
                    heldout=settings.heldout)
        w.candidates = [c for c in w.candidates if c.name in {k.name for k in cands}]
        if not (w.converged and w.stationary):
            # residuals of a fit that stopped short hold the fit failure as much as a missing
            # effect: nothing is named from them
            notes.append(f"{name}: no candidate tested: its base fit did not reach a minimum "
                         f"({w.message})")
            w.candidates = []
        state.update(name, w.problem.values(w.x))
        works.append(w)
    return works, notes


def _propagate(source: Working, works: list[Working], state: ModelState, say) -> None:
    """Re-bind and refit, in order, every problem downstream of ``source`` (its owned keys
    changed), and those downstream of them."""
    state.update(source.name, source.problem.values(source.x))
    changed = {source.name}
    for w in works:
        if w is source or not state.depends(w.name, w.problem, changed):
            continue
        say(f"{w.name}: refit with the new coefficients of {source.name}")
        refresh(w, state.bind(w.problem))
        state.update(w.name, w.problem.values(w.x))
        changed.add(w.name)


def _accept(w: Working, cand: Candidate, trial, ext, group, works, state, say) -> Accepted:
    problem, obj, sol, ext_folds = ext
    w.problem, w.objective, w.sol, w.fold_errors = problem, obj, sol, ext_folds
    w.candidates = [c for c in w.candidates if not set(c.coefficients) & set(cand.coefficients)]
    w.history.append(cand.name)
    w.rejected.clear()
    renoise(w)
    _propagate(w, works, state, say)
    return Accepted(cand.name, w.name, cand.description, trial.coefficients, trial.stderr,
                    trial.error_before_pct, trial.error_after_pct, trial.heldout_before_pct,
                    trial.heldout_after_pct, trial.p_adjusted, group, w.floor_pct,
                    excess_explained(trial.error_before_pct, trial.error_after_pct,
                                     w.floor_pct), sign_note(cand, trial.coefficients),
                    trial.heldout_scheme)


def _upstream_first(rows: list, works: dict, state: ModelState) -> list:
    """The passing rows of problems none of whose upstream problems has a passing row: an
    effect missing upstream (PPY1 on MF/Fy) also misfits the problems built on it (MF/Mz),
    where some other candidate could absorb part of it; the upstream one goes first."""
    hot = {r.problem for r in rows}
    return [r for r in rows
            if not set(state.upstream(r.problem, works[r.problem].problem)) & hot]


def _discover(problems, library, settings, base, say) -> Discovery:
    t0 = time.perf_counter()
    state = ModelState.of(problems, library)
    works, notes = _prepare_all(problems, library, settings, state, say)
    steps, accepted, names = [], [], {c.name: c for c in library.candidates}
    for k in range(1, settings.max_total + 1):
        live = [w for w in works if len(w.history) < settings.max_steps]
        say(f"step {k}: score {sum(len(w.candidates) for w in live)} candidate(s) on "
            f"{len(live)} problem(s)")
        rows, info = _rows(live, settings)
        passing = _upstream_first(
            [r for r in rows if r.passes and r.name not in info[(r.problem, r.name)][0].rejected],
            {w.name: w for w in live}, state)
        passing.sort(key=lambda r: (info[(r.problem, r.name)][2].log_p,
                                    -info[(r.problem, r.name)][2].drop))
        tried, chosen = [], None
        for row in passing[:settings.max_tries]:
            w, cand, s, factor = info[(row.problem, row.name)]
            say(f"step {k}: refit {w.name} with {cand.name}")
            trial, ext = confirm(w, cand, s.step, factor, settings.alpha)
            tried.append(trial)
            if ext is None:
                w.rejected.add(cand.name)  # not retried until this problem's model changes
                continue
            accepted.append(_accept(w, cand, trial, ext, row.ambiguity_group, works, state,
                                    say))
            chosen = cand.name
            break
        if chosen is None and settings.joint:
            found = try_blocks(tried, rows, info, live, settings.alpha, say)
            tried += found[0]
            if found[1] is not None:
                w, cand, trial, ext = found[1]
                names[cand.name] = cand
                accepted.append(_accept(w, cand, trial, ext, (), works, state, say))
                chosen = cand.name
        steps.append(Step(k, tuple(rows), tuple(tried), chosen))
        if chosen is None:
            break
    probs = summaries(works, {w.name: {k: state.owner[k] for k in state.reads(w.problem)}
                              for w in works},
                      {w.name: state.upstream(w.name, w.problem) for w in works})
    accepted = final_accepted(accepted, probs, names)
    floor, explained = headline(accepted, probs)
    return Discovery(base=base or {"kind": "given", "name": "", "tir": None},
                     problems=probs, steps=tuple(steps), accepted=tuple(accepted),
                     noise_floor_pct=floor, excess_explained=explained,
                     conclusion=conclusion(accepted, probs, steps, notes),
                     settings=settings.to_dict(), seconds=time.perf_counter() - t0,
                     state=dict(state.values), sources=state.sources, notes=tuple(notes))
