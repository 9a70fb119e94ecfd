"""Discovery on the real TTC sessions in ``../shared/realdata`` (issue 45), through the command
line as a user runs it. Nothing of the data is copied into the repository; every output goes to
a scratch folder.

Per set (a folder of TTC ``.mat`` files), in the scratch folder:

1. ``mfid import SET/*.mat --out folder``;
2. ``mfid discover folder --only MF`` (the default base: the bundled tyre with every library
   coefficient at its neutral value): which effects it names, which pressure coefficients of
   Fy among them, and which candidates it could not test;
3. ``mfid fit folder`` and ``mfid discover folder --only MF --base FITTED.tir``: the fitted
   pressure terms are in the base, so no pressure coefficient should be named again;
4. one view of the data: every library candidate coefficient the fit identifies beyond
   ``SE_LIMIT`` standard errors must be testable in step 2.

Usage::

    python bench/discovery_real.py [--sets r6 r2] [--work /tmp/discovery-real/bench]
                                   [--json out.json] [--skip-fit]

Prints one block per set; ``--json`` writes the records.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
REALDATA = ROOT / ".." / "shared" / "realdata"
SETS = {"r6": "ttc_r6_deid_lateral_longitudinal",
        "r2": "ttc_r2_b1052_hoosier_20.5x7.0-13"}
MFID = [str(Path(sys.executable).with_name("mfid"))]
PRESSURE = re.compile(r"^(PP[XYZ][0-9]|PPMX1)$")
SE_LIMIT = 5.0


def _mfid(*args: str) -> tuple[subprocess.CompletedProcess, float]:
    t0 = time.perf_counter()
    proc = subprocess.run([*MFID, *args], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"mfid {' '.join(args)}: exit {proc.returncode}\n{proc.stderr}")
    return proc, time.perf_counter() - t0


def _read(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def summary(d: dict) -> dict:
    """What a discovery.json says: accepted effects, pressure keys of Fy among them,
    untestable candidates, base convergence per problem."""
    accepted = d.get("accepted", [])
    problems = d.get("base", {}).get("problems", [])
    keys = sorted({k for a in accepted for k in a["coefficients"]})
    first = d["steps"][0]["candidates"] if d.get("steps") else []
    return {"accepted": [f"{a['name']} ({a['problem']})" for a in accepted],
            "pressure_fy": sorted(k for a in accepted if a["problem"] == "MF/Fy"
                                  for k in a["coefficients"] if PRESSURE.match(k)),
            "pressure_any": sorted(k for k in keys if PRESSURE.match(k)),
            "untestable": sorted(f"{r['name']} ({r['problem']})" for r in first
                                 if not r["testable"]),
            "testable": sorted(f"{r['name']} ({r['problem']})" for r in first
                               if r["testable"]),
            "testable_keys": sorted({k for r in first if r["testable"]
                                     for k in r["coefficients"]}),
            "converged": {p["name"]: bool(p.get("converged")) and bool(p.get("stationary"))
                          for p in problems},
            "heldout": {p["name"]: p.get("heldout_scheme") for p in problems},
            "conclusion": d.get("conclusion", "")}


def candidate_keys(prefix: str = "MF/") -> frozenset[str]:
    """The coefficients of the library's candidates (not the nuisance ones) of the problems
    ``--only MF`` analyses (a relation starting with ``prefix``): PFZ1, which the fit's
    geometry stage fits, is a candidate of the CFz characteristic, not of a trailer stage."""
    from identify.discover.library import load_library
    return frozenset(k for c in load_library().candidates if not c.nuisance
                     and any(r.startswith(prefix) for r in c.relations)
                     for k in c.coefficients)


def identified(fit_json: dict, limit: float = SE_LIMIT,
               keys: frozenset[str] | None = None) -> dict[str, float]:
    """Library candidate coefficients (``keys``, default :func:`candidate_keys`) the MF
    stages fitted beyond ``limit`` standard errors: key -> |value| / stderr."""
    keys = candidate_keys() if keys is None else keys
    out = {}
    for r in fit_json.get("fits", []):
        if r.get("relation") != "MF":
            continue
        for k, v in (r.get("parameters") or {}).items():
            se = (r.get("stderr") or {}).get(k)
            if k in keys and se and se > 0 and abs(v) / se > limit:
                out[k] = max(out.get(k, 0.0), abs(v) / se)
    return out


def run_set(name: str, work: Path, skip_fit: bool = False) -> dict:
    src = REALDATA / SETS[name]
    folder, rec = work / name, {"set": name}
    if not (folder / "tyre.toml").exists():
        _, rec["import_s"] = _mfid("import", *map(str, sorted(src.glob("*.mat"))),
                                   "--out", str(folder))
    _, rec["discover_s"] = _mfid("discover", str(folder), "--only", "MF", "--out",
                                 str(work / f"{name}-discovery"))
    rec["default"] = summary(_read(work / f"{name}-discovery" / "discovery.json"))
    if skip_fit:
        return rec
    _, rec["fit_s"] = _mfid("fit", str(folder), "--out", str(work / f"{name}-fits"),
                            "--no-report")
    fit_json = next((work / f"{name}-fits").rglob("fit.json"))
    tir = next(fit_json.parent.glob("*.tir"))
    rec["fit_identified"] = identified(_read(fit_json))
    rec["identified_not_testable"] = sorted(set(rec["fit_identified"])
                                            - set(rec["default"]["testable_keys"]))
    _, rec["discover_base_s"] = _mfid("discover", str(folder), "--only", "MF", "--base",
                                      str(tir), "--out", str(work / f"{name}-discovery-fitted"))
    rec["fitted_base"] = summary(_read(work / f"{name}-discovery-fitted" / "discovery.json"))
    return rec


def table(records: list[dict]) -> str:
    lines = []
    for r in records:
        d = r["default"]
        lines.append(f"{r['set']}: default base ({r['discover_s']:.0f} s): accepted "
                     f"{', '.join(d['accepted']) or 'none'}; pressure of Fy named: "
                     f"{', '.join(d['pressure_fy']) or 'none'}; base converged {d['converged']}")
        lines.append(f"  untestable: {', '.join(d['untestable']) or 'none'}")
        if "fitted_base" in r:
            f = r["fitted_base"]
            lines.append(f"  fit identifies (|v|/se > {SE_LIMIT:g}): "
                         + ", ".join(f"{k} {v:.0f}" for k, v in r["fit_identified"].items())
                         + f"; not testable in discovery: "
                         f"{', '.join(r['identified_not_testable']) or 'none'}")
            lines.append(f"  fitted base ({r['discover_base_s']:.0f} s): accepted "
                         f"{', '.join(f['accepted']) or 'none'}; pressure named again: "
                         f"{', '.join(f['pressure_any']) or 'none'}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", nargs="+", default=list(SETS), choices=list(SETS))
    ap.add_argument("--work", type=Path, default=Path("/tmp/discovery-real/bench"))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--skip-fit", action="store_true")
    a = ap.parse_args(argv)
    if not REALDATA.is_dir():
        print(f"no real data at {REALDATA}: nothing to run")
        return 0
    a.work.mkdir(parents=True, exist_ok=True)
    records = [run_set(s, a.work, a.skip_fit) for s in a.sets]
    print(table(records))
    if a.json:
        a.json.write_text(json.dumps(records, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
