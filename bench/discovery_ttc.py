"""Discovery on TTC-style trailer sessions (issue 19, acceptance 3 and 4), through the command line
as a user runs it.

Per seed, in a scratch folder:

1. ``base.tir``: the bundled tyre with every MF pressure term at zero (PPX1-4, PPY1-5, PPMX1,
   PPZ1-2): the base model "without pressure terms";
2. ``truth.tir``: the base with the hidden terms set (PPY1 = 0.455346, PPY3 = -0.1, the
   bundled tyre's values, or ``--hide PPY1=0.455346,PPY3=-0.05``; nothing for the null set);
3. ``mfid simulate truth.tir session --format ttc --seed S``: a two-run session (cornering and
   drive/brake, ~136k samples, AR(1) noise, drift, warm-ups, temperature trends, logging
   quirks; ``--cornering-only`` for the cornering run alone);
4. ``mfid import session/*.mat --out folder``;
5. ``mfid discover folder --base base.tir --only MF`` (or ``--only`` as given), and reads
   ``discovery.json``.

"Named" means every hidden key is among the accepted coefficients (alone, in a block, or as
the reported member of an ambiguity group); a false addition is any accepted effect on a
session with nothing hidden. With ``--timing`` it runs one session only and prints the time of
every phase from the progress lines of ``mfid discover`` (acceptance 4).

Usage::

    python bench/discovery_ttc.py [--seeds 20] [--jobs 2] [--only MF] [--cornering-only]
                                  [--sets hidden null] [--json out.json] [--hide K=V,...]
    python bench/discovery_ttc.py --timing [--seed 0]
    python bench/discovery_ttc.py --seeds 20 --jsonl part.jsonl   # records as they arrive
    python bench/discovery_ttc.py --summarise part.jsonl          # a run stopped early
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
TIR = ROOT / "identify" / "simulate" / "data" / "tyre_225_50R17.tir"
MFID = [str(Path(sys.executable).with_name("mfid"))]  # the installed command
PRESSURE_KEYS = re.compile(r"^(PP[XYZ][0-9]|PPMX1)\b")
SETS = {"hidden": {"PPY1": 0.455346, "PPY3": -0.1}, "null": {}}
TARGET = 18  # of 20: named (hidden) or no false addition (null)


def write_tir(path: Path, values: dict[str, float]) -> None:
    """The bundled .tir with every MF pressure term at zero, then ``values`` set."""
    out = []
    for line in TIR.read_text(encoding="utf-8").splitlines():
        m = PRESSURE_KEYS.match(line)
        if m:
            key = m.group(1)
            name, rest = line.split("=", 1)
            comment = rest[rest.index("$"):] if "$" in rest else ""
            line = f"{name}= {values.get(key, 0.0)!r:<24}{comment}"
        out.append(line)
    path.write_text("\n".join(out) + "\n", encoding="utf-8")


def _mfid(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*MFID, *args], cwd=cwd, capture_output=True, text=True, check=True)


def run_one(task: tuple) -> dict:
    """One session: (set name, seed, only, cornering_only, hidden values) -> record."""
    name, seed, only, cornering_only, hidden = task
    with tempfile.TemporaryDirectory(prefix=f"ttc-{name}-{seed}-") as tmp:
        tmp = Path(tmp)
        write_tir(tmp / "base.tir", {})
        write_tir(tmp / "truth.tir", hidden)
        t0 = time.perf_counter()
        sim = ["simulate", "truth.tir", "session", "--format", "ttc", "--seed", str(seed)]
        _mfid(*sim, *(["--cornering-only"] if cornering_only else []), cwd=tmp)
        mats = sorted(str(p.relative_to(tmp)) for p in (tmp / "session").glob("*.mat"))
        _mfid("import", *mats, "--out", "folder", cwd=tmp)
        t1 = time.perf_counter()
        proc = _mfid("discover", "folder", "--base", "base.tir", "--only", only,
                     "--seed", str(seed), "--out", "found", cwd=tmp)
        t2 = time.perf_counter()
        d = json.loads((tmp / "found" / "discovery.json").read_text(encoding="utf-8"))
        samples = sum(r["samples"] for r in json.loads(
            (tmp / "session" / "truth.json").read_text(encoding="utf-8"))["runs"])
    accepted = d.get("accepted", [])
    # the drift candidate is a nuisance (the measurement, not the tyre): absorbing the
    # session's drift is what it is for, so it is counted apart, never as a false addition
    effects = [a for a in accepted if not _nuisance(a)]
    keys = {k for a in effects for k in a["coefficients"]}
    grouped = keys | {k for a in effects for k in a.get("ambiguous_with", [])}
    conclusion = proc.stdout.strip().splitlines()
    return {"set": name, "seed": seed, "hidden": sorted(hidden),
            "hidden_values": dict(hidden), "samples": samples,
            "accepted": [a["name"] for a in accepted],
            "accepted_problems": [a["problem"] for a in accepted],
            "accepted_keys": sorted(keys),
            "named": bool(hidden) and set(hidden) <= grouped,
            "named_exact": bool(hidden) and set(hidden) <= keys,
            "others": sorted(keys - set(hidden)),
            "drift": any(_nuisance(a) for a in accepted),
            "false_addition": not hidden and bool(effects),
            "prepare_s": t1 - t0, "discover_s": t2 - t1,
            "conclusion": conclusion[-1] if conclusion else ""}


def _nuisance(accepted: dict) -> bool:
    return all(k.startswith("MFID_") for k in accepted["coefficients"])


def timing(seed: int, only: str) -> str:
    """One 136k-sample session (hidden PPY1, PPY3): ``mfid discover --only`` timed phase by
    phase, wall and CPU time of this process (the discovery runs in-process, as the command
    line runs it, with its progress messages as phase marks)."""
    from identify.discover.search import Settings
    from identify.workflows.discover import discover_folder

    with tempfile.TemporaryDirectory(prefix="ttc-timing-") as tmp:
        tmp = Path(tmp)
        write_tir(tmp / "base.tir", {})
        write_tir(tmp / "truth.tir", SETS["hidden"])
        _mfid("simulate", "truth.tir", "session", "--format", "ttc", "--seed", str(seed),
              cwd=tmp)
        mats = sorted(str(p.relative_to(tmp)) for p in (tmp / "session").glob("*.mat"))
        _mfid("import", *mats, "--out", "folder", cwd=tmp)
        samples = sum(r["samples"] for r in json.loads(
            (tmp / "session" / "truth.json").read_text(encoding="utf-8"))["runs"])
        marks = []

        def say(msg: str) -> None:
            marks.append((time.perf_counter(), time.process_time(), msg))
            print(f"[{marks[-1][0] - marks[0][0]:7.1f} s] {msg}", file=sys.stderr, flush=True)

        run = discover_folder(tmp / "folder", base_tir=tmp / "base.tir",
                              settings=Settings(seed=seed), out_dir=tmp / "found",
                              only=(only,), progress=say)
        say("end")
    wall = marks[-1][0] - marks[0][0]
    cpu = marks[-1][1] - marks[0][1]
    lines = [f"mfid discover folder --base base.tir --only {only}: {samples} samples "
             f"(hidden PPY1, PPY3; seed {seed}): wall {wall:.0f} s, CPU {cpu:.0f} s "
             f"(one process)", "     wall       CPU  phase"]
    for (t, c, msg), (t2, c2, _) in zip(marks[:-1], marks[1:]):
        lines.append(f"  {t2 - t:7.1f} s {c2 - c:7.1f} s  {msg}")
    accepted = ", ".join(a.name for a in run.discovery.accepted) or "nothing"
    lines.append(f"accepted: {accepted}")
    return "\n".join(lines)


def run(n_seeds: int = 20, jobs: int = 2, only: str = "MF", cornering_only: bool = False,
        sets=("hidden", "null"), seed0: int = 1, jsonl: str | None = None,
        hide: dict[str, float] | None = None) -> list[dict]:
    """Every session's record, the sets interleaved (seed 1 of each, then seed 2 ...); with
    ``jsonl`` each record is appended to that file as it arrives; ``hide`` replaces the hidden
    set's values."""
    values = {**SETS, **({"hidden": dict(hide)} if hide else {})}
    tasks = [(s, seed0 + i, only, cornering_only, values[s]) for i in range(n_seeds)
             for s in sets]
    out = []
    with ProcessPoolExecutor(max(jobs, 1)) as pool:
        for rec in pool.map(run_one, tasks):
            out.append(rec)
            if jsonl:
                with open(jsonl, "a", encoding="utf-8") as f:
                    f.write(json.dumps(rec) + "\n")
    return out


def table(records: list[dict]) -> str:
    lines = []
    for s in dict.fromkeys(r["set"] for r in records):
        rs = [r for r in records if r["set"] == s]
        n = len(rs)
        drift = sum(r["drift"] for r in rs)
        hidden = rs[0].get("hidden_values") or SETS[s]
        if hidden:
            k = sum(r["named"] for r in rs)
            exact = sum(r["named_exact"] for r in rs)
            other = sum(bool(r["others"]) for r in rs)
            values = ", ".join(f"{key} = {v:g}" for key, v in hidden.items())
            lines.append(f"hidden {values}: all named in {k}/{n} (target >= "
                         f"{TARGET}/20; {exact}/{n} by their own names, not as an ambiguity "
                         f"group); another tyre effect added in {other}/{n}; drift absorbed "
                         f"in {drift}/{n}")
            for key in hidden:
                k1 = sum(key in r["accepted_keys"] for r in rs)
                lines.append(f"  {key} named in {k1}/{n}")
        else:
            k = sum(not r["false_addition"] for r in rs)
            lines.append(f"nothing hidden: no false addition in {k}/{n} (target >= "
                         f"{TARGET}/20); drift absorbed in {drift}/{n}")
        for r in rs:
            lines.append(f"  seed {r['seed']:3d}: {', '.join(r['accepted']) or '-'} "
                         f"({r['discover_s']:.0f} s)")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0, help="--timing: the session's seed")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="MF")
    ap.add_argument("--cornering-only", action="store_true")
    ap.add_argument("--sets", nargs="*", default=list(SETS), choices=list(SETS))
    ap.add_argument("--json", default=None)
    ap.add_argument("--timing", action="store_true")
    ap.add_argument("--jsonl", default=None, help="append every record as it arrives")
    ap.add_argument("--hide", default=None, metavar="K=V,...",
                    help="the hidden set's .tir values (default PPY1=0.455346,PPY3=-0.1)")
    ap.add_argument("--summarise", default=None, metavar="JSONL",
                    help="only print the table of a --jsonl file (a run stopped early)")
    a = ap.parse_args(argv)
    if a.summarise:
        with open(a.summarise, encoding="utf-8") as f:
            print(table([json.loads(line) for line in f if line.strip()]))
        return 0
    if a.timing:
        print(timing(a.seed, a.only))
        return 0
    hide = {k.strip(): float(v) for k, v in (kv.split("=") for kv in a.hide.split(","))} \
        if a.hide else None
    records = run(a.seeds, a.jobs, a.only, a.cornering_only, a.sets, jsonl=a.jsonl, hide=hide)
    print(table(records))
    if a.json:
        Path(a.json).write_text(json.dumps(records, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
