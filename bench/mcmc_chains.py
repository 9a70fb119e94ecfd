"""Per-chain summary of an ``mfid fit --mcmc`` run (issue 17, acceptance 4), from its fit.json.

Prints, for every MCMC chain: steps, largest autocorrelation time tau, steps / tau (the 50-tau
rule), why it stopped (past 50 tau, the step cap, the time budget) and its seconds; then the
total chain seconds. Time the run itself with ``/usr/bin/time -v`` (wall and CPU):

    /usr/bin/time -v mfid fit measurements/sample-225-50R17 --mcmc [--mcmc-budget S] \\
        --out /tmp/f --reports /tmp/r
    python bench/mcmc_chains.py /tmp/f/sample-225-50R17
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    doc = json.loads((Path(sys.argv[1]) / "fit.json").read_text())
    total = 0.0
    print(f"{'chain':28s} {'steps':>7s} {'tau':>7s} {'steps/tau':>9s} {'seconds':>8s}  stopped")
    for f in doc["fits"]:
        mc = f.get("mcmc")
        if not mc:
            continue
        taus = [t for t in mc["tau"].values() if t is not None and math.isfinite(t)]
        tau = max(taus) if taus else math.nan
        why = "past 50 tau" if mc["converged"] else (mc.get("stopped") or "max_steps")
        total += mc["seconds"]
        print(f"{f['relation'] + ' [' + f['form'] + ']':28s} {mc['n_steps']:7d} {tau:7.0f} "
              f"{mc['n_steps'] / tau:9.1f} {mc['seconds']:8.0f}  {why}")
    print(f"chains: {total:.0f} s in all")


if __name__ == "__main__":
    main()
