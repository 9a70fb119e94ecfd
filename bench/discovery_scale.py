"""Discovery at trailer-session scale (issue 19): time per phase on ~136k samples, and the noise
diagnosis against the loop it replaced.

1. A synthetic two-run trailer session (:func:`identify.discover.scenarios.make_session`:
   135 sweeps, 136k samples, AR(1) noise, noisy load channel), its MF stage problems
   (``MF/Fx``, ``MF/Fy``, ``MF/Mx``, ``MF/Mz``: what ``mfid discover --only MF`` analyses) and
   one :func:`identify.discover.search.discover` run, timed phase by phase through its progress
   callback (``--hide PPY1=0.4`` for a session with a missing effect).
2. ``noise_scale`` (the per-group lag-one variogram of the residuals) vectorised against the
   former loop over noise groups x sweeps, on the same residuals, in one run: once with the
   session's sweeps, once with the sweeps the former labelling made of a noisy load channel
   of a load channel with 1 % noise (every 2 % sample-to-sample load change started a sweep:
   thousands of sweeps, each its own noise group, which is how a real 136k-sample session sat
   in it for 40 minutes). The labelling now looks for load steps in a running median.

Usage::

    python bench/discovery_scale.py [--samples 136000] [--hide PPY1=0.4] [--seed 0]
                                    [--no-compare]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from identify.discover.library import load_library  # noqa: E402
from identify.discover.noise import PHI_MIN, fit_ar1, sweep_index  # noqa: E402
from identify.discover.prepared_problem import noise_scale  # noqa: E402
from identify.discover.problems import Base, apply_base, trailer_problems  # noqa: E402
from identify.discover.scenarios import base_tir, make_session  # noqa: E402
from identify.discover.search import Settings, discover  # noqa: E402
from identify.fit.relations.problems import Context  # noqa: E402


def _variogram_loop(r, index, max_lag=3):
    """The former pooled variogram: a Python loop over sweeps per lag."""
    out = np.full(max_lag, np.nan)
    for h in range(1, max_lag + 1):
        d = [r[idx[h:]] - r[idx[:-h]] for idx in index if idx.size > h]
        if d:
            d = np.concatenate(d)
            out[h - 1] = 0.5 * float(d @ d) / d.size
    return out


def noise_scale_loop(e, index, groups):
    """The former noise_scale: for every noise group, a list over every sweep's index array
    (groups x sweeps, each touching the group mask)."""
    gam1 = np.full(e.size, np.nan)
    for g in np.unique(groups):
        sel = groups == g
        sub = [idx[sel[idx]] for idx in index if sel[idx].sum() > 1]
        gam1[sel] = _variogram_loop(e, sub, 1)[0] if sub else np.nan
    if not np.all(np.isfinite(gam1) & (gam1 > 0)):
        return 0.0, np.full(e.size, np.nan)
    en = e / np.sqrt(gam1)
    phi, s2 = fit_ar1(_variogram_loop(en, index))
    return phi, np.sqrt(gam1) if phi < PHI_MIN else np.sqrt(gam1 * s2)


def _timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def compare_noise_scale(problem, truth) -> list[str]:
    """Former loop vs vectorised noise_scale on one problem's residuals at the true
    coefficients (the noise), in the same run."""
    vals = {**problem.values(), **{k: truth[k] for k in problem.parameters if k in truth}}
    e = problem.model(vals) - problem.measured
    lines = []
    layouts = {"session sweeps": (problem.sweeps, np.asarray(problem.extra["noise_group"]))}
    # the former labelling: a new sweep at every raw 2 % load step, on a load channel with 1 %
    # noise (a wheel's once-per-revolution ripple and the load cell's noise)
    fz = np.asarray(problem.extra["Fz_N"], dtype=float)
    fz = fz * (1.0 + 0.01 * np.random.default_rng(1).standard_normal(fz.size))
    brk = np.ones(fz.size, dtype=bool)
    brk[1:] = (np.abs(np.diff(fz)) > 0.02 * np.abs(fz[:-1])) | (problem.sweeps[1:]
                                                                 != problem.sweeps[:-1])
    raw = np.cumsum(brk) - 1
    layouts["sweeps of the former raw-load labelling"] = (raw, raw)
    for name, (sweeps, groups) in layouts.items():
        index = sweep_index(sweeps, e.size)
        (phi_v, s_v), t_v = _timed(noise_scale, e, index, groups)
        listed = list(index)
        (phi_l, s_l), t_l = _timed(noise_scale_loop, e, listed, groups)
        same = np.allclose(s_v, s_l, rtol=1e-9, equal_nan=True)
        lines.append(f"noise_scale, {name}: {len(index)} sweeps, {np.unique(groups).size} "
                     f"noise groups: loop {t_l:.3f} s, vectorised {t_v:.4f} s, ratio "
                     f"{t_l / max(t_v, 1e-9):.0f}x (same stds: {same}, phi {phi_l:.3f} vs "
                     f"{phi_v:.3f})")
    return lines


class Phases:
    """The progress callback: a time stamp per phase."""

    def __init__(self):
        self.t0 = time.perf_counter()
        self.marks: list[tuple[float, str]] = []

    def __call__(self, text: str) -> None:
        self.marks.append((time.perf_counter() - self.t0, text))
        print(f"[{self.marks[-1][0]:7.1f} s] {text}", flush=True)

    def table(self, end: float) -> list[str]:
        stamps = [t for t, _ in self.marks] + [end]
        groups: dict[str, float] = {}
        for (t, text), nxt in zip(self.marks, stamps[1:]):
            if "base fit" in text:
                key = "base fits and diagnosis"
            elif "score" in text:
                key = "scoring"
            elif "refit" in text and "new coefficients" in text:
                key = "updates of downstream problems"
            else:
                key = "refits with held-out folds"
            groups[key] = groups.get(key, 0.0) + nxt - t
        return [f"  {k}: {v:.1f} s" for k, v in groups.items()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=136_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hide", default=None, help="KEY=VALUE in the data, neutral in the base")
    ap.add_argument("--no-compare", action="store_true",
                    help="skip the noise_scale comparison with the former loop (minutes)")
    args = ap.parse_args(argv)
    hidden = None
    if args.hide:
        k, v = args.hide.split("=")
        hidden = {k.strip().upper(): float(v)}
    t0 = time.perf_counter()
    frame, truth = make_session(np.random.default_rng(args.seed), args.samples, hidden=hidden)
    tir = base_tir()
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    library = load_library()
    problems = [apply_base(p, Base(), library, tir)
                for p in trailer_problems(frame, tir, ctx, with_rr=False)]
    t_build = time.perf_counter() - t0
    print(f"session: {len(frame)} samples, {frame['run'].nunique()} runs; problems "
          + ", ".join(f"{p.extra['name']} ({p.measured.size})" for p in problems)
          + f"; generated and built in {t_build:.1f} s")
    if not args.no_compare:
        fy = next(p for p in problems if p.extra["name"] == "MF/Fy")
        print("\n".join(compare_noise_scale(fy, truth)), flush=True)
    phases = Phases()
    d = discover(problems, library, Settings(seed=args.seed), progress=phases)
    end = time.perf_counter() - phases.t0
    print(f"discover: {end:.1f} s on {len(frame)} samples ({os.cpu_count()} cpus visible; "
          "one thread)")
    print("\n".join(phases.table(end)))
    print(d.conclusion)
    return 0


if __name__ == "__main__":
    sys.exit(main())
