"""Joint effects: blocks of candidates that only generalise together.

When the conditions of a test move together (load and pressure in a rolling-resistance table
of five load/pressure pairs), one coefficient alone absorbs part of another's effect: each
single addition passes the score and F tests, yet its held-out error rises, because what it
learned is a mixture that does not carry over to other conditions. Only the pair generalises.
So before concluding that nothing is missing, a step whose single candidates passed the F test
but failed the held-out check tests the **blocks** they form:

- every pair of such a candidate with another testable candidate of the same problem (those
  that passed the F or score test first, then by p-value): the partner may be insignificant
  alone, its effect being absorbed by the other's;
- the ambiguity group of such a candidate, as a whole.

And when no single candidate passed the score test at all (each alone explains too little:
its effect and the other's cancel along the direction the design confounds), every pair of
testable candidates of a table (no sweeps) whose error is clearly above its noise floor
(:data:`UNEXPLAINED`) is scored; a pair is tried when it passes and predicts at least
:data:`JOINT_GAIN` times the drop of its better member.

A block is a candidate of several coefficients (:func:`merge`), scored with the block score
test (q coefficients), refitted and confirmed like a single one, at a Bonferroni level over
every test of the step plus the blocks, and reported as one named effect with each coefficient.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np

from identify.discover.confirm import confirm
from identify.discover.library import Candidate
from identify.discover.result import Trial
from identify.discover.score import score_candidates

__all__ = ["merge", "blocks", "try_blocks", "MAX_BLOCKS", "JOINT_SEP"]

MAX_BLOCKS = 6
"""Most blocks scored per problem and step after held-out failures."""
MAX_PAIRS = 15
"""Most pairs scored per problem when no single candidate passed."""
MAX_TRIES = 3
"""Most blocks refitted per step."""
JOINT_GAIN = 2.0
"""Without held-out failures, a pair must predict at least this multiple of its best member's
drop of the residual sum of squares (it explains what neither explains alone)."""
UNEXPLAINED = 1.5
"""Pairs of candidates that are insignificant alone are scored only when the problem's error
is above this multiple of its noise floor estimate."""
JOINT_SEP = "+"
"""Separator of the names in a block's name (``QSY7+QSY8``)."""


def merge(cands: list[Candidate]) -> Candidate:
    """One candidate freeing every coefficient of ``cands`` (names joined by ``+``)."""
    coefs, bounds, eqs = {}, {}, []
    for c in cands:
        coefs.update(c.coefficients)
        bounds.update(c.bounds)
        if c.equation not in eqs:
            eqs.append(c.equation)
    rels = tuple(dict.fromkeys(r for c in cands for r in c.relations))
    desc = cands[0].description + "".join(f", and {c.description}" for c in cands[1:])
    return Candidate(name=JOINT_SEP.join(c.name for c in cands), coefficients=coefs,
                     bounds=bounds, relations=rels, equation="; ".join(eqs),
                     description=f"{desc} (jointly: only the block generalises)",
                     expected_sign="", source="joint")


def blocks(failed: list[Candidate], partners: list[Candidate],
           groups: list[tuple[str, ...]], by_name: dict[str, Candidate],
           tried: set[str]) -> list[Candidate]:
    """The blocks to score (module doc), at most :data:`MAX_BLOCKS`, pairs first.

    Parameters
    ----------
    failed : candidates that passed the F test and failed the held-out check
    partners : other testable candidates of the problem, most promising first
    groups : ambiguity groups of the problem's candidates (names)
    by_name : every live candidate of the problem by name
    tried : block names already rejected (not retried until the problem changes)
    """
    out: dict[str, Candidate] = {}
    failed_names = [c.name for c in failed]
    pool = list(dict.fromkeys(failed_names + [c.name for c in partners]))
    for g in groups:
        if set(g) & set(failed_names):
            pool += [n for n in g if n not in pool and n in by_name]
    for a, b in combinations(pool, 2):
        if a in failed_names or b in failed_names:
            block = merge([by_name[a], by_name[b]])
            if block.name not in tried:
                out.setdefault(block.name, block)
    for g in groups:
        members = [n for n in g if n in by_name]
        if len(members) > 2 and set(members) & set(failed_names):
            block = merge([by_name[n] for n in members])
            if block.name not in tried:
                out.setdefault(block.name, block)
    return list(out.values())[:MAX_BLOCKS]


def _score_blocks(w, todo: list[Candidate]) -> dict:
    """Block scores of one problem, from the candidate columns of this step's scoring."""
    cached = getattr(w, "columns", {}) or {}
    vals = w.problem.values(w.x)
    cols = {}
    for b in todo:
        parts = [c.name for c in w.candidates if c.name in b.name.split(JOINT_SEP)]
        if len(parts) == len(b.name.split(JOINT_SEP)) and all(n in cached for n in parts):
            cols[b.name] = np.hstack([cached[n].reshape(cached[n].shape[0], -1)
                                      for n in parts])
        else:
            cols[b.name] = w.objective.columns(w.x, {k: vals[k] for k in b.coefficients})
    kind = w.noise.kind if w.noise.kind == "cluster" else "independent"
    scores, _ = score_candidates(w.sol.r, w.sol.jac, cols, kind=kind,
                                 clusters=w.objective.index)
    return scores


def _candidate_blocks(w, tried, rows, failed, alpha) -> tuple[list[Candidate], bool]:
    """(blocks of ``w``, whether they come from held-out failures)."""
    by_name = {c.name: c for c in w.candidates}
    mine = [by_name[t.name] for t in failed if t.problem == w.name and t.name in by_name]
    f_pass = {t.name for t in tried if t.problem == w.name and t.p_adjusted <= alpha}
    mine_rows = sorted((r for r in rows if r.problem == w.name and r.name in by_name
                        and r.testable),
                       key=lambda r: (not (r.passes or r.name in f_pass), r.p_value))
    groups = [(r.name,) + tuple(r.ambiguity_group) for r in rows
              if r.problem == w.name and r.ambiguity_group]
    if mine:
        return blocks(mine, [by_name[r.name] for r in mine_rows], groups, by_name,
                      w.rejected), True
    # no single passed at all: every pair, most promising first, when the error of a table is
    # clearly above its noise floor (something is unexplained); sweeps have the power to
    # show a single effect, and their floor at this stage is a lower bound
    if w.has_sweeps or not (np.isfinite(w.floor_pct)
                            and w.error_pct() > UNEXPLAINED * w.floor_pct):
        return [], False
    names = [r.name for r in mine_rows]
    pairs = [merge([by_name[a], by_name[b]]) for a, b in combinations(names, 2)]
    return [b for b in pairs if b.name not in w.rejected][:MAX_PAIRS], False


def try_blocks(tried: list[Trial], rows: list, info: dict, live: list, alpha: float,
               say) -> tuple[list[Trial], tuple | None]:
    """Score, refit and confirm blocks when no single candidate was accepted (module doc).

    Returns
    -------
    trials : the block refits tried
    accepted : (working problem, block candidate, trial, replacement) of the first block
        accepted, or None
    """
    failed = [t for t in tried if t.p_adjusted <= alpha
              and not t.heldout_after_pct < t.heldout_before_pct]
    todo = []
    for w in live:
        found, from_failures = _candidate_blocks(w, tried, rows, failed, alpha)
        if failed and not from_failures:
            continue  # held-out failures elsewhere: only their blocks
        todo += [(w, b, from_failures) for b in found]
    if not todo:
        return [], None
    factor = sum(1 for r in rows if r.testable) + len(todo)  # Bonferroni: step + blocks
    single = {(key[0], key[1]): v[2] for key, v in info.items()}
    passing = []
    for w in live:
        mine = [(b, f) for ww, b, f in todo if ww is w]
        if not mine:
            continue
        scores = _score_blocks(w, [b for b, _ in mine])
        for b, from_failures in mine:
            sc = scores[b.name]
            if not sc.testable or min(1.0, factor * sc.p_value) > alpha:
                continue
            best = max((single[(w.name, n)].drop for n in b.name.split(JOINT_SEP)
                        if (w.name, n) in single), default=0.0)
            if not from_failures and sc.drop < JOINT_GAIN * best:
                continue  # the block is not more than its best member
            passing.append((w, b, sc))
    trials = []
    for w, b, sc in sorted(passing, key=lambda t: t[2].log_p)[:MAX_TRIES]:
        say(f"{w.name}: no single addition generalises; refit the block {b.name}")
        trial, ext = confirm(w, b, sc.step, factor, alpha)
        trials.append(trial)
        if ext is not None:
            return trials, (w, b, trial, ext)
        w.rejected.add(b.name)
    return trials, None
