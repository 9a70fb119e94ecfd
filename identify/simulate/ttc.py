"""``simulate_ttc``: a two-run Tire Test Consortium session from a .tir, with known truth.

Real TTC files may not be redistributed, so the tests run on this generator instead: it
reproduces the format (identify.io.ttc.files: the channel names, units and SAE signs, ``.mat`` v5
with the ``channel`` struct and the strings, tab-separated ``.dat`` with a three-line header),
the structure of a session (identify.simulate.ttc_plan: pressure blocks, warm-ups, load and
camber steps, continuous sweeps, transitions), the drift and temperatures of a real machine
(identify.simulate.ttc_signals) and its logging quirks (identify.simulate.ttc_quirks).

The output folder holds, per run, ``<testid>run<N>.mat`` and ``.dat`` (the same data), and
``truth.json``: the .tir values used, every set point, every segment (kind, start and end
time, set points) and every quirk injected. Equal seeds give byte-identical files.
"""
from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.io

from identify.core.atomic import temp_dir
from identify.core.errors import InputError
from identify.core.version import __version__
from identify.io.ttc.mat73 import write_mat73
from identify.model.modes import TRAILER_MODE
from identify.simulate.artefacts import run_rng
from identify.simulate.coefficients import DEFAULT_RELATIONS
from identify.simulate.folder import _move_into_place, _numeric_params, _prepare_target
from identify.simulate.model import TyreModel
from identify.simulate.rig import DEFAULT_RIG
from identify.simulate.ttc_plan import RATE, programme, session_plan
from identify.simulate.ttc_quirks import IMPLAUSIBLE, inject, make_implausible
from identify.simulate.ttc_signals import actual_conditions, to_file_units, ttc_channels

__all__ = ["RUNS", "TESTID", "TtcSession", "simulate_ttc"]

TESTID = "SIM1"
#: (run number, test) of the two runs of a session.
RUNS = ((4, "cornering"), (7, "drive_brake"))
#: Decimals of each .dat column (a TTC .dat has a fixed resolution per channel).
_DECIMALS = {"ET": 2, "V": 3, "N": 3, "SA": 4, "IA": 4, "RL": 4, "RE": 4, "P": 3, "FX": 2,
             "FY": 2, "FZ": 2, "MX": 3, "MZ": 3, "NFX": 5, "NFY": 5, "RST": 2, "TSTI": 2,
             "TSTC": 2, "TSTO": 2, "AMBTMP": 2, "SR": 5, "SL": 5, "RUN": 0}


@dataclass(frozen=True)
class TtcSession:
    """What :func:`simulate_ttc` wrote: the folder, the files, ``truth.json``'s content."""

    path: Path
    files: tuple[Path, ...]
    truth: dict


def _write_mat(path: Path, ch: Mapping[str, np.ndarray], units: Mapping[str, str],
               strings: Mapping[str, str], version: str = "5") -> None:
    names = list(ch)
    if version == "7.3":
        write_mat73(path, ch, {"channel": {"name": names, "units": [units[n] for n in names]}},
                    strings)
        return
    content = {name: np.asarray(ch[name], dtype=float).reshape(-1, 1) for name in names}
    content["channel"] = {"name": np.array(names, dtype=object),
                          "units": np.array([units[n] for n in names], dtype=object)}
    content.update(strings)
    scipy.io.savemat(path, content, format="5", oned_as="column")
    # the header holds a creation time: write a fixed one so equal seeds give equal files
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 5.0 MAT-file, Platform: mfid, Created on: simulated".ljust(116))


def _write_dat(path: Path, title: str, ch: Mapping[str, np.ndarray],
               units: Mapping[str, str]) -> None:
    names = list(ch)
    table = pd.DataFrame({n: np.round(ch[n], _DECIMALS.get(n, 6)) for n in names})
    table["RUN"] = table["RUN"].astype(np.int64)
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(f"{title}\n" + "\t".join(names) + "\n" + "\t".join(units[n] for n in names)
                 + "\n")
        table.to_csv(fh, sep="\t", header=False, index=False, na_rep="NaN",
                     lineterminator="\n")


def _segments(prog, et: np.ndarray) -> list[dict]:
    out = []
    for seg in prog.segments:
        d = {"kind": seg["kind"], "t_start": float(et[seg["start"]]),
             "t_end": float(et[seg["stop"] - 1]),
             **{k: v for k, v in seg.items() if k not in ("kind", "start", "stop")}}
        out.append(d)
    return out


def simulate_ttc(tir_params: Mapping[str, float], outdir: str | Path, *, seed: int = 0,
                 noise: float = 0.01, ar1: float = 0.7, units: str = "SI",
                 implausible: Sequence[str] = (), cornering_only: bool = False,
                 tireid: str = "mfid-sim 225/50 R17", mat_version: str = "5",
                 relaxation: float = 0.0, input_noise: float | None = None,
                 overwrite: bool = False) -> TtcSession:
    """Write a simulated TTC session (``.mat`` and ``.dat`` per run, ``truth.json``).

    Parameters
    ----------
    tir_params : mapping
        Numeric .tir values in SI (the truth; missing keys take defaults).
    outdir : str or Path
        Folder to create (absent or empty unless ``overwrite``).
    seed : int
        Seed of every random step (durations, drift, noise, quirks).
    noise : float
        Noise standard deviation as a fraction of each channel's RMS [-].
    ar1 : float
        Lag-one correlation of the noise [-].
    units : {"SI", "USCS"}
        The file's unit system.
    implausible : sequence of str
        Channels to make implausible: ``N`` (near zero at 40 kph), ``RE`` (hundreds of
        metres), ``SR`` (pinned at -1).
    cornering_only : bool
        Write the cornering run only.
    tireid : str
        The ``tireid`` string of the files.
    mat_version : {"5", "7.3"}
        MATLAB format of the ``.mat`` files: v5 (what ``save -v7`` writes, uncompressed) or
        v7.3 (HDF5 inside, identify.io.ttc.mat73).
    relaxation : float [m]
        Lateral relaxation length: the model sees the slip angle through a first-order lag
        of this rolling distance, the SA channel records the slip angle set
        (identify.simulate.ttc_signals.lagged_slip); 0 (default): none.
    input_noise : float or None
        Noise of the operating-condition channels (slip angle and ratios, camber, load,
        speeds; identify.simulate.ttc_signals.INPUT_CHANNELS) as a fraction of each one's
        RMS [-]; None (default): ``noise``. 0 gives inputs known exactly, errors in the
        forces and moments only.
    overwrite : bool
        Replace a non-empty ``outdir``.

    Raises
    ------
    InputError
        Bad settings or an occupied ``outdir``.
    """
    outdir = Path(outdir)
    if units not in ("SI", "USCS"):
        raise InputError(None, f"units must be SI or USCS, not {units!r}", key="--units")
    if mat_version not in ("5", "7.3"):
        raise InputError(None, f"mat_version must be 5 or 7.3, not {mat_version!r}",
                         key="--mat-version")
    bad = [n for n in implausible if n not in IMPLAUSIBLE]
    if bad:
        raise InputError(None, f"unknown implausible channel {bad[0]!r} (one of "
                               f"{', '.join(IMPLAUSIBLE)})", key="--implausible")
    if not noise >= 0 or not -1 < ar1 < 1:
        raise InputError(None, f"noise must be >= 0 and ar1 in (-1, 1), got {noise}, {ar1}")
    if input_noise is not None and not input_noise >= 0:
        raise InputError(None, f"input noise must be >= 0, not {input_noise}",
                         key="--input-noise")
    if not 0 <= relaxation < 10:
        raise InputError(None, f"relaxation must be in [0, 10) m, not {relaxation}",
                         key="--relaxation")
    params = _numeric_params(tir_params)
    model = TyreModel(params, DEFAULT_RELATIONS, DEFAULT_RIG)
    plan = session_plan(model.fz0, model.p0)
    _prepare_target(outdir, overwrite)
    strings = {"source": f"mfid {__version__} simulate --format ttc (not TTC data)",
               "testid": TESTID, "tireid": tireid}
    truth = {"generator": "identify.simulate.ttc", "mfid_version": __version__,
             "seed": int(seed), "noise": noise, "ar1": ar1,
             "input_noise": noise if input_noise is None else input_noise, "units": units,
             "mat_version": mat_version, "relaxation_m": relaxation,
             "implausible": list(implausible), "axes": "SAE", "rate_Hz": RATE,
             "model_mode": TRAILER_MODE, "tir": params, "plan": plan.to_dict(),
             "strings": strings, "runs": []}
    outdir.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_dir(outdir)
    files = []
    try:
        for number, test in RUNS[:1] if cornering_only else RUNS:
            rng = run_rng(seed, f"ttc-{test}")
            prog = programme(plan, "cornering" if test == "cornering" else "drive_brake", rng)
            act = actual_conditions(prog, rng)
            si = ttc_channels(model, act, number, rng=rng, noise=noise, ar1=ar1,
                              relaxation=relaxation, input_noise=input_noise)
            in_sweep = act["kind"] == 4
            segments = _segments(prog, si["ET"])
            ch, unit_names = to_file_units(si, units)
            ch = make_implausible(ch, implausible, rng)
            ch, quirks = inject(ch, in_sweep, rng, drive_brake=test != "cornering")
            stem = f"{TESTID}run{number}"
            _write_mat(tmp / f"{stem}.mat", ch, unit_names, strings, mat_version)
            title = f"{TESTID} run {number} ({test}): {tireid}; {strings['source']}"
            _write_dat(tmp / f"{stem}.dat", title, ch, unit_names)
            files += [outdir / f"{stem}.mat", outdir / f"{stem}.dat"]
            truth["runs"].append({"run": number, "test": test, "stem": stem,
                                  "samples": int(ch["ET"].size), "quirks": quirks,
                                  "segments": segments})
        text = json.dumps(truth, indent=1, allow_nan=False) + "\n"
        (tmp / "truth.json").write_text(text, encoding="utf-8")
        _move_into_place(tmp, outdir, overwrite)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return TtcSession(outdir, tuple(files), json.loads(text))

