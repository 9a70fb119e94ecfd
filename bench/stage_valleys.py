"""Does an MF stage of a generated TTC fit have a second minimum as good as the one reported?

Takes a folder kept by ``bench/ttc_truth.py --keep DIR`` (one seed: ``DIR/ttc-seedN``), builds
the stage's points as ``mfid fit`` did (segmented, binned), and solves the stage again from the
truth's coefficients (the other stages' at their fitted values). It prints the objective at
the reported fit, at the truth, and at the minimum reached from the truth, and the named
coefficients at each with the reported standard errors.

When the minimum reached from the truth is as low as the reported one but far away in the
named coefficients, the data hold two minima the noise cannot tell apart, and the reported
(linearised) intervals describe only the one the search found (docs/intervals.md).

``--lhs N`` also solves the stage from N Latin-hypercube starts in the fit's start box around
the reported values (identify.fit.mf.search.start_points, seed ``--seed``) and lists every
distinct minimum they reach, lowest first, with its objective difference to the reported fit
in the same units: a minimum below the reported one is one the fit's search missed; one
within the 95 % region's 3.84 is a second answer the data cannot rule out. ``--profile``
holds each named coefficient at the truth's value, re-solves the others, and prints the
objective's rise in the same units: below 3.84, a likelihood-ratio interval would hold the
truth whether or not the reported (linearised) one does.

    python bench/ttc_truth.py --seeds 2 --keep /tmp/tt
    python bench/stage_valleys.py /tmp/tt/ttc-seed2 --stage Fx0 --names PCX1 PEX1 PEX4
    python bench/stage_valleys.py /tmp/tt/ttc-seed2 --stage Fy --names RBY1 RCY1 REY1 --lhs 8
    python bench/stage_valleys.py /tmp/tt/ttc-seed2 --names PCX1 PEX1 --profile
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from identify.fit.limits import table_limits
from identify.fit.mf.search import start_points
from identify.fit.mf.stages import stage_problem
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from identify.fit.run import FitSettings
from identify.fit.solve import engine
from identify.fit.solve.engine import MF_SOLVE
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.segment import SegmentSettings
from identify.workflows.fit import _mf_trailer  # the table exactly as mfid fit builds it
from identify.workflows.trailer_prep import prepare_trailer


def _numbers(values) -> dict[str, float]:
    return {k: float(v) for k, v in values.items() if isinstance(v, (int, float))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("seed_dir", help="a ttc-seedN folder kept by bench/ttc_truth.py --keep")
    ap.add_argument("--stage", default="Fx0")
    ap.add_argument("--names", nargs="+", default=["PCX1", "PEX1", "PEX4"])
    ap.add_argument("--lhs", type=int, default=0,
                    help="also list the minima reached from this many box starts")
    ap.add_argument("--seed", type=int, default=0, help="seed of the --lhs starts")
    ap.add_argument("--profile", action="store_true",
                    help="also the profile of the objective at each named coefficient's truth")
    args = ap.parse_args()
    base = Path(args.seed_dir)
    mset = load_folder(base / "folder")
    settings = FitSettings()
    td = prepare_trailer(mset, SegmentSettings(bin_alpha_deg=settings.bin_alpha_deg,
                                               bin_kappa=settings.bin_kappa),
                         segment=settings.segment)
    trailer = _mf_trailer(td, float(mset.manifest.tyre.nominal_load_N), settings, None)
    fit_dir = next((base / "fits").iterdir())
    fitted = _numbers(read_tir(next(fit_dir.glob("*.tir"))).values)
    # the validity limits the stages' constraints had: the table's ranges
    # (identify.fit.limits.table_limits, as identify.fit.mf.stages.fit_mf sets them); the
    # written .tir has those of the points the fits kept, which can differ slightly, and a
    # point the fit's validity constraints excluded would look like a missed lower minimum
    fitted.update(table_limits(trailer))
    truth = _numbers(json.loads((base / "ttc" / "truth.json").read_text())["tir"])
    reported = next(f for f in json.loads((fit_dir / "fit.json").read_text())["fits"]
                    if f.get("relation") == "MF" and f.get("form") == args.stage)
    recorded = FitResult.from_dict(reported)  # its intervals: Student's t at the recorded dof
    free = {args.stage: list(reported["parameters"])}
    sp = stage_problem(args.stage, trailer, fitted, free=free, hold={})
    problem = sp.problem

    def cost(values: dict[str, float]) -> float:
        r = problem.residuals(np.array([values[n] for n in problem.free]))
        return float(r @ r)

    start = {**fitted, **{n: truth[n] for n in problem.free}}
    again = fit(stage_problem(args.stage, trailer, start, free=free, hold={}).problem,
                starts=np.array([[start[n] for n in problem.free]]))
    rows = [("reported fit", fitted), ("truth", start), ("from the truth", again.parameters)]
    x = np.array([fitted[n] for n in problem.free])
    r = problem.residuals(x)  # the reported fit's
    c0 = float(r @ r)
    print(f"{args.stage}: {problem.measured.size} points, {len(problem.free)} free; "
          f"objective relative to the reported fit's")
    print(f"{'':16s}{'objective':>11s}" + "".join(f"{n:>10s}" for n in args.names))
    for label, values in rows:
        print(f"{label:16s}{cost(values) / c0:11.5f}"
              + "".join(f"{values[n]:10.4g}" for n in args.names))
    print(f"{'reported sd':16s}{'':11s}"
          + "".join(f"{reported['stderr'].get(n, float('nan')):10.2g}" for n in args.names))
    # the difference in the units of the noise: chi^2 with iid noise (s^2 from the reported
    # fit's residuals), and divided by the variance the reported intervals add over iid ones
    # (their median ratio), which is what a 95 % region of the reported kind would allow
    s2 = c0 / (r.size - x.size)
    iid = np.sqrt(np.diag(engine.covariance(engine.residual_jacobian(problem, x), r)))
    inflation = float(np.median([(reported["stderr"][n] / sd) ** 2
                                 for n, sd in zip(problem.free, iid) if sd > 0]))
    dchi2 = (cost(again.parameters) - c0) / s2
    print(f"from the truth - reported: {dchi2:+.1f} in iid chi^2; the reported intervals are "
          f"{np.sqrt(inflation):.2f} x the iid ones (median), so {dchi2 / inflation:+.2f} on "
          "their scale (a 95 % region of one coefficient: 3.84)")
    if args.lhs > 0:
        _minima(problem, args, cost, c0, s2, inflation, again.parameters)
    if args.profile:
        print("profile: the named coefficient held at the truth's value, the others re-solved "
              "from the reported fit and from the minimum reached from the truth:")
        for name in args.names:
            ends = []
            for values in (fitted, again.parameters):
                held = stage_problem(args.stage, trailer, {**fitted, **values, name: truth[name]},
                                     free={args.stage: [n for n in free[args.stage]
                                                        if n != name]}, hold={}).problem
                ends.append({**fitted, **fit(held, starts=held.x0()[None, :],
                                             tol=MF_SOLVE).parameters, name: truth[name]})
            d = (min(cost(v) for v in ends) - c0) / s2
            print(f"{name:>8s} = {truth[name]:<10.4g}{d:+8.1f} in iid chi^2, "
                  f"{d / inflation:+6.2f} on the reported intervals' scale (95 %: 3.84); "
                  f"the reported 95 % interval {fitted[name]:.4g} +- "
                  f"{recorded.quantile(name) * reported['stderr'][name]:.3g}")


def _minima(problem, args, cost, c0, s2, inflation, from_truth) -> None:
    """Solve ``problem`` (at the reported values) from the reported values and ``args.lhs``
    box starts; print the distinct minima, with the one reached from the truth
    (``from_truth``): the named coefficients within 2 % and the objectives within 1 in iid
    chi^2 are one."""
    starts = start_points(problem, args.lhs, args.seed)
    ends = [fit(problem, starts=x[None, :], tol=MF_SOLVE).parameters for x in starts]

    def same(a, b) -> bool:
        x, y = (np.array([v[n] for n in args.names]) for v in (a, b))
        return bool(np.all(np.abs(x - y) <= 0.02 * np.maximum(np.abs(y), 1e-2))
                    and abs(cost(a) - cost(b)) <= s2)

    found: list[dict[str, float]] = []
    for values in sorted(ends + [from_truth], key=cost):
        if not any(same(values, f) for f in found):
            found.append(values)
    print(f"minima from the reported values, {args.lhs} box starts (seed {args.seed}) and the "
          "truth, lowest first; chi^2 difference to the reported fit on the reported "
          "intervals' scale:")
    for values in found:
        hits = sum(same(e, values) for e in ends)
        print(f"{'':16s}{cost(values) / c0:11.5f}"
              + "".join(f"{values[n]:10.4g}" for n in args.names)
              + f"   {(cost(values) - c0) / s2 / inflation:+8.2f}   ({hits} of "
                f"{len(starts)} starts)")


if __name__ == "__main__":
    main()
