"""Calibration of the reparametrised Fy0 MCMC stage (issue 17, acceptance 5).

Fy0 on trailer sessions like the bundled sample's (3 pressures x 3, 5, 7 kN, below the
cornering-stiffness peak, where PKY1, PKY2, PKY4 lie on a curved ridge): each of ``--trials``
seeded data sets (1 % noise, the simulator's definition) is fitted as ``mfid fit`` does
(fit_mf, the other stages at the truth) and sampled by stage_mcmc with the Kya
reparametrisation (identify.fit.mcmc.reparam); prints every trial's steps, largest tau and
seconds, then the share of 90 % credible intervals that hold the true coefficient (the bar:
>= 85 % of 40 trials) and how many chains passed 50 tau. The same count is the trials test
``tests/trials/test_fit_calibration_mf_trials.py::test_reparametrised_fy0_covers_the_truth_on_the_sample_loads``.

    python bench/mcmc_calibration.py [--trials 40] [--loads 3000 5000 7000] [--no-reparam]
                                     [--ridge-only] [--json out.json]

``--ridge-only`` frees only PKY1, PKY2, PKY4 (the other coefficients at the truth): the ridge
the reparametrisation is for, at a fraction of the cost of the whole stage (27 free
coefficients on this design; lateral runs only, as the Fy0 stage selects them). It is a
reduced check, not the stage's calibration.

``--no-reparam`` samples PKY1, PKY2, PKY4 directly (tau ~ 1700 steps on these loads: hours).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.unit.test_fit_calibration import MIN_RATE, N_TRIALS  # noqa: E402
from tests.unit.test_fit_calibration_mf import LOADS_N, calibrate_stage, design  # noqa: E402

RIDGE = ("PKY1", "PKY2", "PKY4")


def ridge_only(n_trials: int, loads, reparam: bool, seed0: int = 2000) -> dict:
    """The calibration with only PKY1, PKY2, PKY4 free (see the module docstring)."""
    points = design(loads=tuple(loads))
    return calibrate_stage("Fy0", n_trials, seed0, points[points["run"].str.startswith("lat")],
                           verbose=True, reparam=reparam, free={"Fy0": list(RIDGE)},
                           label="MF-Fy0 ridge only")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=N_TRIALS)
    ap.add_argument("--loads", type=float, nargs="+", default=list(LOADS_N), metavar="N")
    ap.add_argument("--no-reparam", action="store_true")
    ap.add_argument("--ridge-only", action="store_true")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    if args.ridge_only:
        s = ridge_only(args.trials, args.loads, not args.no_reparam)
    else:
        s = calibrate_stage("Fy0", n_trials=args.trials, points=design(loads=tuple(args.loads)),
                            verbose=True, reparam=not args.no_reparam)
    ok = s["rate"] >= MIN_RATE and s["converged"] == s["trials"]
    print(f"Fy0 {'reparametrised' if not args.no_reparam else 'direct'}, loads "
          f"{', '.join(f'{f:g}' for f in args.loads)} N: coverage {s['rate']:.1%} "
          f"({s['hits']}/{s['total']}, bar {MIN_RATE:.0%}), {s['converged']}/{s['trials']} "
          f"chains past 50 tau: {'PASS' if ok else 'FAIL'}")
    if args.json:
        args.json.write_text(json.dumps(s, indent=1))


if __name__ == "__main__":
    main()
