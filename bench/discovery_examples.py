"""The discovery transcripts of docs/commands.md, produced by the commands that page shows.

Runs, in a scratch folder (the page's ``cd /tmp``), through the ``mfid`` command line:

- ``worked``: the worked example: a base .tir without PPY5 (the bundled tyre with
  ``PPY5 = 0``), ``mfid simulate base.tir hidden --hide PPY5=-0.15``, then
  ``mfid discover hidden --base base.tir``;
- ``null``: ``mfid simulate base.tir nothing`` and ``mfid discover nothing --base base.tir -q``;
- ``thesis``: ``mfid discover measurements/thesis-225-50R17 -q`` (the real thesis table);
- ``confounded``: ``mfid discover rr-table -q`` on a rolling-resistance table of five
  load/pressure pairs at four speeds with QSY7 and QSY8 in the data
  (:func:`identify.discover.scenarios.make_confounded`, seed 1), and the same with
  ``--heldout pressure`` (leave-one-pressure-out folds).

and prints each transcript as it belongs in docs/commands.md (stdout and stderr as a terminal
shows them; the timed progress lines, ``[  1.2 s] ...``, left out, since their times vary). The test
``tests/unit/test_discover_examples.py`` runs it and compares every transcript with the page.

    python bench/discovery_examples.py [--workdir DIR] [--only NAME ...]
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from identify.cli.app import app  # noqa: E402
from identify.discover.scenarios import make_confounded  # noqa: E402

EXAMPLES = ("worked", "null", "thesis", "confounded")
PROGRESS = re.compile(r"^\[\s*[0-9.]+ s\] ")
TYRE_TOML = """[tyre]
id = "rr-table"
nominal_pressure_Pa = 250000
nominal_load_N = 4000
unloaded_radius_m = 0.3135
source = "simulated"

[[runs]]
id = "rolling-resistance"
file = "characteristics.csv"
kind = "characteristics"
test = "any"
axes = "ISO-W"
"""


@contextmanager
def _cwd(path: Path):
    old = Path.cwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


def mfid(*args: str) -> str:
    """Run ``mfid ARGS`` in this process; the transcript without progress lines."""
    from typer.testing import CliRunner

    res = CliRunner().invoke(app, list(args), catch_exceptions=False)
    if res.exit_code != 0:
        raise RuntimeError(f"mfid {' '.join(args)} failed ({res.exit_code}):\n{res.output}")
    text = (res.stderr or "") + (res.stdout or "")
    return "\n".join(line for line in text.splitlines() if not PROGRESS.match(line))


def base_tir(path: Path) -> Path:
    """The bundled tyre with PPY5 = 0 (docs/commands.md's ``sed 's/^PPY5 .*/PPY5 = 0/'``)."""
    from identify.simulate import default_tir_path

    text = Path(default_tir_path()).read_text()
    path.write_text(re.sub(r"(?m)^PPY5 .*$", "PPY5 = 0", text))
    return path


def rr_table(folder: Path, seed: int = 1) -> Path:
    """The confounded rolling-resistance table as a measurement folder."""
    problem, _ = make_confounded(np.random.default_rng(seed))
    fz, pb = problem.extra["Fz_N"], problem.pressure_bar
    vx = problem.extra["Vx_mps"]
    rows = ["quantity,pi_bar,Fz_N,value,unit,Vx_mps"]
    rows += [f"FxRR,{p:g},{f:g},{v:.6g},N,{s:g}"
             for p, f, v, s in zip(pb, fz, problem.measured, vx)]
    folder.mkdir(exist_ok=True)
    (folder / "tyre.toml").write_text(TYRE_TOML)
    (folder / "characteristics.csv").write_text("\n".join(rows) + "\n")
    return folder


def run(workdir: Path, only=EXAMPLES) -> dict[str, str]:
    """Every transcript (name -> text), run in ``workdir``."""
    out = {}
    workdir.mkdir(parents=True, exist_ok=True)
    with _cwd(workdir):
        if {"worked", "null"} & set(only):
            base_tir(Path("base.tir"))
        if "worked" in only:
            if not Path("hidden").exists():
                mfid("simulate", "base.tir", "hidden", "--hide", "PPY5=-0.15")
            out["worked"] = mfid("discover", "hidden", "--base", "base.tir")
        if "null" in only:
            if not Path("nothing").exists():
                mfid("simulate", "base.tir", "nothing")
            out["null"] = mfid("discover", "nothing", "--base", "base.tir", "-q")
        if "thesis" in only:
            out["thesis"] = mfid("discover", str(ROOT / "measurements" / "thesis-225-50R17"),
                                 "-q")
        if "confounded" in only:
            rr_table(Path("rr-table"))
            out["confounded"] = (mfid("discover", "rr-table", "-q") + "\n"
                                 + mfid("discover", "rr-table", "--heldout", "pressure", "-q"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workdir", type=Path, default=None)
    ap.add_argument("--only", nargs="*", default=list(EXAMPLES))
    args = ap.parse_args(argv)
    work = args.workdir or Path(tempfile.mkdtemp(prefix="mfid-discovery-"))
    for name, text in run(work, tuple(args.only)).items():
        print(f"--- {name}")
        print("\n".join("    " + line if line else "" for line in text.splitlines()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
