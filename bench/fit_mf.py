"""Wall time of the Magic Formula stages on the bundled sample folder's trailer data.

Fits geometry, Fx0, Fy0, Mz0, Fx, Fy, Mz, Mx, My (identify.fit.mf.stages.fit_mf, no MCMC) to
the trailer runs of ``measurements/sample-225-50R17`` and prints, per stage: points, free and held
coefficients, global-search statistics, seconds and the thesis error (total and per pressure).
The part of ``bench/fit.py``'s 60 s budget the MF stages may take is about 40 s.

    python bench/fit_mf.py [--folder DIR] [--start defaults|truth] [--stages S ...]
                           [--mcmc STAGE] [--json out.json]

``--stages`` fits only those stages (the others stay at the start values). ``--mcmc STAGE``
then samples that stage's posterior as ``mfid fit --mcmc`` does (identify.fit.mf.stages.
stage_mcmc, seed 0, the default chain cap) and prints its steps, largest autocorrelation time,
acceptance, seconds and, if the cap stopped it, the cap that would let it reach 50 tau.

``--start defaults`` (default) starts where ``mfid fit`` starts: the MFeval defaults with the
folder's nominal load, pressure and radius. ``--start truth`` starts from the .tir the
simulator used (truth.json), the easy case.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from identify.fit.mf.stages import DEFAULT_STAGES, fit_mf, stage_mcmc  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402
from identify.model.parameters import defaults  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "measurements" / "sample-225-50R17"
BUDGET_S = 40.0


def _base(mset, start: str, folder: Path) -> dict[str, float]:
    if start == "truth":
        tir = json.loads((folder / "truth.json").read_text())["tir"]
        return {k: float(v) for k, v in tir.items() if not isinstance(v, str)}
    base = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    tyre = mset.manifest.tyre
    base["FNOMIN"] = float(tyre.nominal_load_N)
    base["NOMPRES"] = base["INFLPRES"] = float(tyre.nominal_pressure_Pa)
    if tyre.unloaded_radius_m:
        base["UNLOADED_RADIUS"] = float(tyre.unloaded_radius_m)
    return base


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--folder", type=Path, default=FOLDER)
    ap.add_argument("--start", choices=("defaults", "truth"), default="defaults")
    ap.add_argument("--stages", nargs="+", choices=DEFAULT_STAGES, default=DEFAULT_STAGES)
    ap.add_argument("--mcmc", choices=DEFAULT_STAGES, help="sample this stage's posterior")
    ap.add_argument("--json", type=Path, help="write the numbers to this file")
    args = ap.parse_args()

    t0 = time.perf_counter()
    mset = load_folder(args.folder)
    t_load = time.perf_counter() - t0
    trailer = mset.trailer
    base = _base(mset, args.start, args.folder)
    t1 = time.perf_counter()
    mf = fit_mf(trailer, base, stages=tuple(args.stages))
    t_fit = time.perf_counter() - t1

    print(f"{args.folder.name}: {len(trailer)} trailer points, start = {args.start}, "
          f"load {t_load:.1f} s (not counted)")
    head = f"{'stage':8} {'points':>7} {'free':>5} {'held':>5} {'best':>6} {'s':>7} {'thesis %':>9}"
    print(head + "   per pressure [bar: %]")
    rows = []
    for r in mf.results:
        by_p = "  ".join(f"{p:g}: {e:.3f}" for p, e in r.error_by_pressure_pct.items())
        print(f"{r.form:8} {r.n_points:7d} {len(r.free):5d} {len(mf.held[r.form]):5d} "
              f"{r.starts_at_best:>2}/{r.n_starts:<3} {r.seconds:7.2f} {r.error_total_pct:9.3f}"
              f"   {by_p}" + ("" if r.converged else "   NOT CONVERGED: " + r.message))
        rows.append({"stage": r.form, "points": r.n_points, "free": len(r.free),
                     "held": len(mf.held[r.form]), "n_starts": r.n_starts,
                     "starts_at_best": r.starts_at_best, "seconds": r.seconds,
                     "error_total_pct": r.error_total_pct, "converged": r.converged,
                     "error_by_pressure_pct": {f"{p:g}": e
                                               for p, e in r.error_by_pressure_pct.items()}})
    stage_s = sum(r.seconds for r in mf.results)
    print(f"MF stages: {t_fit:.1f} s wall ({stage_s:.1f} s in the optimiser, the rest is data "
          f"selection, identifiability screens and constraint grids); budget about "
          f"{BUDGET_S:.0f} s of bench/fit.py's 60 s")
    mcmc = None
    if args.mcmc:
        from identify.report.tables import mcmc_shortfall

        cpu0 = time.process_time()
        r = stage_mcmc(trailer, mf, args.mcmc)
        cpu = time.process_time() - cpu0
        mcmc = r.mcmc.to_dict()
        tau, name = max((t, n) for n, t in r.mcmc.tau.items())
        print(f"MCMC {args.mcmc}: {r.n_points} points, {len(r.free)} free, "
              f"{r.mcmc.n_walkers} walkers x {r.mcmc.n_steps} steps, largest tau {tau:.0f} "
              f"({name}), steps/tau {r.mcmc.n_steps / tau:.1f}, acceptance "
              f"{r.mcmc.acceptance:.2f}, {r.mcmc.seconds:.0f} s wall, {cpu:.0f} s CPU, "
              f"converged {r.mcmc.converged}"
              + (f" (sampled {', '.join(r.mcmc.reparametrised)})"
                 if r.mcmc.reparametrised else "")
              + (f"; {mcmc_shortfall(r.mcmc)}" if not r.mcmc.converged else ""))
    if args.json:
        args.json.write_text(json.dumps({"folder": str(args.folder), "start": args.start,
                                         "load_seconds": t_load, "fit_seconds": t_fit,
                                         "stages": rows, "mcmc": mcmc}, indent=2,
                                        default=float))


if __name__ == "__main__":
    main()
