"""Fit benchmarks (issue 5, acceptance 6).

1. Wall time of the full fit of the bundled sample folder without MCMC (target <= 60 s on the
   2-core project machine).
2. Effective MCMC samples per second for the CFy relation on the thesis characteristics
   (target >= 1000 effective samples in <= 30 s).

    python bench/fit.py [--folder measurements/sample-225-50R17]
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from identify.fit.mcmc.chains import run_mcmc  # noqa: E402
from identify.fit.optimize import fit  # noqa: E402
from identify.fit.relations import problems as R  # noqa: E402
from identify.io.folder import load_folder  # noqa: E402
from identify.model.parameters import defaults  # noqa: E402
from identify.workflows.fit import FitSettings, fit_folder  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=ROOT / "measurements" / "sample-225-50R17")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        stages: list[tuple[str, float]] = []

        def progress(text: str) -> None:
            now = time.perf_counter()
            stages.append((text, now))

        t0 = time.perf_counter()
        run = fit_folder(args.folder, out_root=tmp, settings=FitSettings(seed=0),
                         progress=progress)
        total = time.perf_counter() - t0
        print(f"full fit of {args.folder.name} without MCMC: {total:.1f} s "
              f"(target <= 60 s) -> {len(run.results)} fits")
        marks = stages + [("end", time.perf_counter())]
        for (name, t_a), (_, t_b) in zip(marks, marks[1:]):
            print(f"  {t_b - t_a:6.2f} s  {name}")
    thesis = load_folder(ROOT / "measurements" / "thesis-225-50R17")
    t = {k: float(v) for k, v in defaults().items() if isinstance(v, (int, float))}
    ctx = R.Context(5000.0, 2.5, t)
    problem = R.cfy(thesis.characteristics, ctx, form="linear_load")
    result = fit(problem)
    t0 = time.perf_counter()
    sampled = run_mcmc(problem, result, seed=0)
    dt = time.perf_counter() - t0
    m = sampled.mcmc
    print(f"MCMC, CFy linear_load on the thesis data: {m.n_samples} effective samples in "
          f"{dt:.1f} s = {m.n_samples / dt:.0f} per second (target >= 1000 in <= 30 s); "
          f"tau max {max(m.tau.values()):.0f} steps, acceptance {m.acceptance:.2f}, "
          f"{m.n_walkers} walkers x {m.n_steps} steps")


if __name__ == "__main__":
    main()
