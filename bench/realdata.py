"""Real measurements as the judge of the pipeline: import, fit and held-out error per set.

For every set of real trailer files (the sub-folders of ``../shared/realdata`` from the
repository root that hold trailer files; ``--sets DIR ...`` for others), this

1. imports the files with ``mfid import`` into a scratch folder (timed);
2. fits it with ``mfid fit`` for the default pipeline (report included: the wall time a user
   waits) and each variant (``--no-segment``, ``--no-bin``, ``--no-revolution-average``;
   ``--no-report``), each in its own process, timed;
3. evaluates every fitted .tir on ALL loaded samples with a positive load (not only the
   samples the fit kept): per force and moment (Fx, Fy, Mz, Mx) the pooled error
   100 RMS(model - measured) / RMS(measured) over every sample, and the project's metric (the
   thesis metric, /work/shared/spec/pressure-relations.md: the same ratio per pressure level,
   then the plain mean over the levels; the levels found from every loaded sample's pressure by
   :func:`pressure_levels`, independently of the segmentation judged). A freely rolling run's
   slip-ratio channel is taken as 0
   there, as the fit takes it (identify.fit.mf.stage_data.rolling_kappa);
4. held-out error: where the set holds several pressure levels, leave-one-pressure-out (each
   level's samples removed from the loaded table before the segmentation, the rest fitted, the
   removed samples predicted, those whose camber, load band and kind of slip the remaining
   data hold at two pressure levels or more, or at the other level of a two-level set:
   :func:`covered`; a fold that removes the only
   camber sweep, or leaves the drive/brake runs at one pressure, would otherwise judge an
   extrapolation in camber or an effect of pressure no remaining sample shows); else the
   sweeps of the default segmentation split into
   ``--folds`` seeded groups, each held out in turn. Each fold is fitted in this process with
   :func:`identify.workflows.fit.fit_measurements` (the loaded set without the fold's samples)
   for the default and every variant. The held-out error of a variant is the mean over the
   folds of the pooled error on the fold's samples (the thesis metric with a fold as the
   level); the pooled error over all held-out samples is given too, and the in-sample error of
   the full fit on the same samples;
5. the verdict: per force and moment, whether the default's held-out error is the best or tied
   (at most ``TIE`` times the best variant's). A channel is judged on a fold only where the
   fold excites it: the RMS of the measured channel over the fold's held-out samples is at
   least ``EXCITED_SHARE`` of its RMS over all the set's samples (:func:`excitation`).
   Elsewhere the channel barely leaves zero (Fx on a fold of cornering runs only, where the
   tyre rolls free), its relative error is a ratio of two small numbers that says nothing
   of the model, and the fold is reported as "not excited" for that channel and left out of
   its held-out means (and so of the verdict); a channel no fold excites has no verdict;
6. where the segmentation leaves samples out: the samples per kind of segment (warm-up,
   transition, partial sweep, isolated sweep, steady stretch) and per filter, from the default
   fit's fit.json.

``--published SET=TIR`` also evaluates a published .tir on the same samples (the acceptance
asks Fy, Mz and Fx of the default at most 0.8x the published fit's error on all samples).

    nice python bench/realdata.py                # every set under ../shared/realdata
    python bench/realdata.py --quick             # default and --no-segment, two folds at most
    python bench/realdata.py --sets DIR [DIR ...] [--published NAME=FILE.tir]
    python bench/realdata.py --work W --reuse --variants no-bin   # a part, beside a former run
    make realdata

The tables go to stdout and, with the records, to bench/results/realdata.{md,json}
(git-ignored). Fits run one at a time, niced (the machine is shared); scratch files go to
``--work`` (a temporary folder, removed unless ``--keep``).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("MPLBACKEND", "Agg")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Mapping, Sequence  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

# nearest_level is used here and, as realdata.nearest_level, by bench/pressure_cut.py
from identify.core.levels import dense_levels, nearest_level  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
REALDATA = ROOT.parent / "shared" / "realdata"
RESULTS = ROOT / "bench" / "results"
TRAILER_SUFFIXES = (".mat", ".dat", ".csv", ".h5", ".hdf5", ".tdx")
CHANNELS = ("Fx", "Fy", "Mz", "Mx")
VARIANTS: dict[str, tuple[str, ...]] = {
    "default": (),
    "no-segment": ("--no-segment",),
    "no-bin": ("--no-bin",),
    "no-revolution-average": ("--no-revolution-average",),
}
"""Variant name -> its ``mfid fit`` flags."""
QUICK_VARIANTS = ("default", "no-segment")
TIE = 1.05
"""The default is tied with the best variant when its held-out error is at most this many times
the best one's."""
EXCITED_SHARE = 0.25
"""A fold excites a channel when the channel's RMS over the fold's samples is at least this share
of its RMS over all the set's samples (:func:`excitation`)."""
NICE = 10
"""Niceness of the fits: the machine is shared."""
PRESSURE_GAP = 5000.0
"""[Pa] pressures closer than this are one level (:func:`pressure_levels`)."""


# ----- pure functions ---------------------------------------------------------------------


@dataclass(frozen=True)
class ChannelError:
    """The error of a model on one force or moment.

    Attributes
    ----------
    pooled_pct : float   100 RMS(model - measured) / RMS(measured) over every sample [%]
    thesis_pct : float   the same per group (pressure level or fold), then the mean [%]
    n : int              samples
    """

    pooled_pct: float
    thesis_pct: float
    n: int


def rms_pct(measured: np.ndarray, model: np.ndarray) -> float:
    """100 sqrt(sum (model - measured)^2 / sum measured^2) [%] over the finite pairs (NaN when
    none, or when every measured value is 0)."""
    m = np.asarray(measured, float)
    f = np.asarray(model, float)
    ok = np.isfinite(m) & np.isfinite(f)
    den = float(np.sum(m[ok] ** 2))
    if not ok.any() or den == 0.0:
        return math.nan
    return 100.0 * math.sqrt(float(np.sum((f[ok] - m[ok]) ** 2)) / den)


def channel_error(measured: np.ndarray, model: np.ndarray, groups: np.ndarray) -> ChannelError:
    """Pooled and per-group-mean (thesis) error of one channel; ``groups`` labels every sample
    (the mean is over the groups with a finite error)."""
    measured = np.asarray(measured, float)
    model = np.asarray(model, float)
    groups = np.asarray(groups)
    per = [rms_pct(measured[groups == g], model[groups == g]) for g in np.unique(groups)]
    per = [e for e in per if math.isfinite(e)]
    n = int(np.sum(np.isfinite(measured) & np.isfinite(model)))
    return ChannelError(rms_pct(measured, model), float(np.mean(per)) if per else math.nan, n)


def pressure_levels(p: np.ndarray, gap: float = PRESSURE_GAP, share: float = 0.02,
                    dense: float = 0.005) -> list[float]:
    """Pressure levels [Pa] of the loaded samples (identify.core.levels.dense_levels, which
    splits levels a slow ramp joins); fit.json's every-sample record finds them the same way."""
    return dense_levels(p, gap, share, dense)


@dataclass(frozen=True)
class Fold:
    """One held-out group: its name and the loaded-table rows it holds out."""

    name: str
    rows: np.ndarray  # boolean mask over the loaded trailer table


def pressure_folds(p: np.ndarray, levels: Sequence[float]) -> list[Fold]:
    """Leave-one-pressure-out: one fold per level, holding out the samples nearest to it."""
    idx = nearest_level(p, levels)
    return [Fold(f"p {lv / 1e3:.0f} kPa", idx == k) for k, lv in enumerate(levels)
            if np.any(idx == k)]


def sweep_folds(sweep_of_row: np.ndarray, n_folds: int, seed: int) -> list[Fold]:
    """Held-out sweeps: the sweeps (labels >= 0 in ``sweep_of_row``; -1 rows are in none) dealt
    into ``n_folds`` groups in a seeded random order, each held out in turn."""
    sweeps = np.unique(sweep_of_row[sweep_of_row >= 0])
    if sweeps.size < 2:
        return []
    order = np.random.default_rng(seed).permutation(sweeps)
    k = min(n_folds, sweeps.size)
    folds = []
    for i in range(k):
        held = order[i::k]
        folds.append(Fold(f"sweeps {','.join(str(int(s)) for s in sorted(held))}",
                          np.isin(sweep_of_row, held)))
    return folds


def condition_cells(table: pd.DataFrame) -> np.ndarray:
    """A label per sample of the conditions it was measured at, apart from the pressure: the
    camber to the nearest degree, the load in bands 30 % wide, and which slips are swept (a
    slip ratio beyond 0.02, a slip angle beyond 1 deg)."""
    gamma = np.rint(np.degrees(table["gamma"].to_numpy(float)))
    fz = np.abs(table["Fz"].to_numpy(float))
    band = np.floor(np.log(np.maximum(fz, 1.0) / 100.0) / np.log(1.3))
    kappa = np.abs(table["kappa"].to_numpy(float)) > 0.02
    alpha = np.abs(np.degrees(table["alpha"].to_numpy(float))) > 1.0
    cells = np.stack([np.nan_to_num(gamma, nan=999), np.nan_to_num(band, nan=999),
                      kappa, alpha], axis=1)
    return np.unique(cells, axis=0, return_inverse=True)[1].ravel()


def covered(cells: np.ndarray, held: np.ndarray, ok: np.ndarray, level: np.ndarray,
            min_levels: int = 2) -> np.ndarray:
    """The held-out samples whose conditions (:func:`condition_cells`) the fitted samples hold
    at ``min_levels`` pressure levels or more (``level``: a sample's pressure level).

    A leave-one-pressure-out fold then measures a prediction across pressure from a pressure
    trend the fitted data show, not an extrapolation to a camber, load or kind of run the
    remaining data never saw, nor a pressure effect they cannot show (a kind of run left at
    one pressure)."""
    fit = ~held & ok
    pairs = np.unique(np.stack([cells[fit], level[fit]], axis=1), axis=0)
    cell_ids, n_levels = np.unique(pairs[:, 0], return_counts=True)
    seen = cell_ids[n_levels >= min_levels]
    return held & ok & np.isin(cells, seen)


def excitation(measured: np.ndarray, rows: np.ndarray, every: np.ndarray) -> float:
    """RMS of ``measured`` over ``rows`` over its RMS over ``every`` (boolean masks; the
    finite values only): the share of the set's excitation of a channel a fold holds (NaN
    without finite values, or with an RMS of 0 over ``every``)."""
    m = np.asarray(measured, float)
    fin = np.isfinite(m)

    def rms(mask: np.ndarray) -> float:
        x = m[mask & fin]
        return float(np.sqrt(np.mean(x ** 2))) if x.size else math.nan

    whole = rms(every)
    return rms(rows) / whole if whole > 0 else math.nan


def excited(share: float, threshold: float = EXCITED_SHARE) -> bool:
    """Whether a fold with this :func:`excitation` share judges the channel."""
    return bool(math.isfinite(share) and share >= threshold)


def sweep_rows(table: pd.DataFrame, segments: Sequence[Mapping]) -> np.ndarray:
    """Per row of the loaded table, the number of the sweep segment it lies in (-1 for none):
    a segment's ``start``/``stop`` are row positions within its run."""
    out = np.full(len(table), -1, dtype=int)
    run = table["run"].astype(str).to_numpy()
    pos = table.groupby("run", sort=False).cumcount().to_numpy()
    k = 0
    for s in segments:
        if s["kind"] != "sweep":
            continue
        out[(run == str(s["run"])) & (pos >= s["start"]) & (pos < s["stop"])] = k
        k += 1
    return out


def left_out(segmentation: Mapping | None) -> list[tuple[str, int, int]]:
    """Where the segmentation left samples out: (why, segments, samples) per segment kind other
    than a sweep, then (filter name, -1, samples removed) per filter that removed any, from
    fit.json's ``data_quality.trailer.segmentation``."""
    if not segmentation:
        return []
    out: dict[str, list[int]] = {}
    for s in segmentation["segments"]:
        if s["kind"] != "sweep":
            c = out.setdefault(s["kind"], [0, 0])
            c[0] += 1
            c[1] += int(s["stop"]) - int(s["start"])
    rows = [(k, v[0], v[1]) for k, v in sorted(out.items(), key=lambda kv: -kv[1][1])]
    rows += [(f"filter: {f['name']}", -1, int(f["removed"])) for f in segmentation["filters"]
             if f["removed"]]
    return rows


def verdict(heldout: Mapping[str, Mapping[str, float]], tie: float = TIE,
            not_excited: Sequence[str] = ()) -> dict[str, dict[str, object]]:
    """Per channel: the best variant, the default's ratio to it, and whether the default is the
    best or tied (ratio at most ``tie``); ``heldout`` is variant -> channel -> error [%]
    (channels without a finite default error are left out). A channel in ``not_excited`` (no
    fold excites it) is ``{"not_excited": True}``, judged neither way."""
    out: dict[str, dict[str, object]] = {}
    for ch in CHANNELS:
        if ch in not_excited:
            out[ch] = {"not_excited": True}
            continue
        vals = {v: e[ch] for v, e in heldout.items() if math.isfinite(e.get(ch, math.nan))}
        if "default" not in vals:
            continue
        best = min(vals, key=vals.get)
        ratio = vals["default"] / vals[best] if vals[best] > 0 else 1.0
        out[ch] = {"best": best, "ratio": ratio, "ok": bool(ratio <= tie)}
    return out


# ----- model on samples -------------------------------------------------------------------


def evaluable(table: pd.DataFrame) -> np.ndarray:
    """Rows the model can be evaluated at: finite inputs and a positive load."""
    ok = table["Fz"].to_numpy(float) > 0
    for c in ("Vx", "alpha", "kappa", "gamma", "p"):
        ok &= np.isfinite(table[c].to_numpy(float))
    return ok


def model_inputs(table: pd.DataFrame) -> pd.DataFrame:
    """The table as the fit sees its slips: a freely rolling run's kappa is 0."""
    from identify.fit.mf.stage_data import rolling_kappa
    return rolling_kappa(table)


def predict(params: Mapping[str, float], table: pd.DataFrame) -> dict[str, np.ndarray]:
    """Fx, Fy, Mz, Mx of ``params`` at every row of ``table`` (ISO-W, SI), evaluated as the
    fits evaluate (useMode FIT_MODE)."""
    from identify.model.evaluate import evaluate
    from identify.model.modes import FIT_MODE
    out = evaluate(params, table["Fz"].to_numpy(float), table["kappa"].to_numpy(float),
                   table["alpha"].to_numpy(float), table["gamma"].to_numpy(float),
                   table["Vx"].to_numpy(float), table["p"].to_numpy(float), mode=FIT_MODE)
    return {c: np.asarray(out[c], float) for c in CHANNELS}


def errors(table: pd.DataFrame, model: Mapping[str, np.ndarray], groups: np.ndarray,
           rows: np.ndarray | None = None) -> dict[str, ChannelError]:
    """Per channel the error of ``model`` on ``table`` (rows ``rows``; every row when None)."""
    rows = np.ones(len(table), bool) if rows is None else rows
    out = {}
    for c in CHANNELS:
        if c not in table.columns or not np.isfinite(table[c].to_numpy(float)[rows]).any():
            continue
        out[c] = channel_error(table[c].to_numpy(float)[rows], model[c][rows], groups[rows])
    return out


# ----- running ----------------------------------------------------------------------------


def mx_by_run_kind(table: pd.DataFrame, models: Mapping[str, Mapping[str, np.ndarray]],
                   groups: np.ndarray, ok: np.ndarray) -> dict[str, dict[str, float]]:
    """Per fit the Mx error on the freely rolling runs (those the Mx stage fits:
    identify.fit.mf.stage_data.run_sweeps) and on the other runs (drive/brake), and the other
    runs' share of the all-sample squared Mx error [%]; empty without Mx or without both
    kinds of run.

    Returns
    -------
    dict
        ``{fit: {"rolling": ChannelError as dict, "other": ..., "other_sse_share_pct": float}}``
    """
    from identify.fit.mf.stage_data import run_sweeps
    if "Mx" not in table.columns:
        return {}
    rolling = run_sweeps(table)[2]
    measured = table["Mx"].to_numpy(float)
    ok = ok & np.isfinite(measured)
    parts = {"rolling": ok & rolling, "other": ok & ~rolling}
    if not all(r.any() for r in parts.values()):
        return {}
    out = {}
    for v, m in models.items():
        sq = (m["Mx"] - measured) ** 2
        rec = {k: dataclasses.asdict(channel_error(measured[r], m["Mx"][r], groups[r]))
               for k, r in parts.items()}
        rec["other_sse_share_pct"] = float(100 * np.nansum(sq[parts["other"]])
                                           / np.nansum(sq[ok]))
        out[v] = rec
    return out


def mfid(*args: str) -> tuple[float, float, int, str]:
    """Run ``mfid ARGS`` niced in its own process: (wall time [s], CPU time [s] (user + system,
    the process and its children), exit code, last output). On a shared machine the wall time
    counts the other users' load too; the CPU time does not."""
    exe = Path(sys.executable).with_name("mfid")
    # niceness NICE in all (this process may have been started niced already)
    cmd = ["nice", "-n", str(max(NICE - os.nice(0), 0)), str(exe), *args]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, p.returncode, (p.stdout + p.stderr)[-3000:]


def variant_settings(name: str):
    """The FitSettings of a variant (as its ``mfid fit`` flags set them) for the fits made in
    this process, which judge the .tir alone: without the report's pressure hold-out."""
    from identify.fit.run import FitSettings
    s = FitSettings(pressure_holdout=False)
    if name == "no-segment":
        return dataclasses.replace(s, segment=False)
    if name == "no-bin":
        return dataclasses.replace(s, bin_alpha_deg=None, bin_kappa=None)
    if name == "no-revolution-average":
        return dataclasses.replace(s, revolution_average=False)
    return s


def trailer_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in TRAILER_SUFFIXES)


def find_sets(dirs: Sequence[str] | None) -> list[Path]:
    """The sets to judge: ``dirs``, or every sub-folder of REALDATA with trailer files."""
    if dirs:
        return [Path(d) for d in dirs]
    if not REALDATA.is_dir():
        return []
    return sorted(d for d in REALDATA.iterdir() if d.is_dir() and trailer_files(d))


def _stages(fit_json: Mapping) -> dict[str, dict[str, object]]:
    def status(f: Mapping) -> object:  # the fit's status; older fit.json: identification
        return f.get("fit_status") or (f.get("identification") if f.get("converged")
                                       else "failed")

    return {f["form"]: {"status": status(f),
                        "error_pct": f.get("error_total_pct"),
                        "points": f.get("n_points")}
            for f in fit_json.get("fits", []) if f.get("relation") == "MF"}


def _tir_params(path: Path) -> dict[str, float]:
    from identify.io.tir import read_tir
    return read_tir(path).params()


def judge_set(folder: Path, work: Path, variants: Sequence[str], *, n_folds: int, seed: int,
              max_folds: int | None, published: Sequence[Path], say,
              reuse: bool = False) -> dict:
    """Import, fit and judge one set (see the module notes); the record of the set. ``reuse``:
    the import and the full fits a former run left in ``work`` are taken as they are (their
    times are then unknown), only what is missing is made."""
    from identify.io.folder import load_folder
    from identify.workflows.fit import fit_measurements

    name = folder.name
    files = trailer_files(folder)
    rec: dict = {"set": name, "path": str(folder), "files": [p.name for p in files]}
    if not files:
        rec["skipped"] = "no trailer files"
        return rec
    meas = work / name / "measurement"
    if reuse and (meas / "tyre.toml").is_file():
        say(f"{name}: the import in {meas} reused")
        wall, cpu, code, out = math.nan, math.nan, 0, ""
    else:
        say(f"{name}: import {len(files)} file(s)")
        wall, cpu, code, out = mfid("import", *map(str, files), "--out", str(meas))
    rec["import"] = {"seconds": wall, "cpu_seconds": cpu, "exit": code}
    if code != 0:
        rec["import"]["output"] = out
        say(f"{name}: import failed (exit {code})\n{out}")
        return rec
    mset = load_folder(meas)
    table = mset.trailer.reset_index(drop=True)
    tyre_id = mset.manifest.tyre.id
    inputs = model_inputs(table)
    ok = evaluable(inputs)
    rec["samples"] = {"loaded": len(table), "evaluated": int(ok.sum())}

    # full fits, one process each
    fits: dict[str, dict] = {}
    for v in variants:
        out_dir = work / name / "fits" / v
        args = ["fit", str(meas), "--out", str(out_dir), "--reports", str(work / name / "reports"
                                                                            / v)]
        # the variants are judged by their .tir: no report (the default makes it, as a
        # user's fit does: its wall time is the one a user waits)
        args += list(VARIANTS[v]) + ([] if v == "default" else ["--no-report"])
        fj_path = out_dir / tyre_id / "fit.json"
        if reuse and fj_path.is_file():
            say(f"{name}: the fit {v} in {out_dir} reused")
            wall, cpu, code, out = math.nan, math.nan, 1 if json.loads(
                fj_path.read_text()).get("failed") else 0, ""
        else:
            say(f"{name}: fit {v}")
            wall, cpu, code, out = mfid(*args)
        fj = json.loads(fj_path.read_text()) if fj_path.is_file() else {}
        fits[v] = {"seconds": wall, "cpu_seconds": cpu, "exit": code, "report": v == "default",
                   "failed": fj.get("failed", []), "stages": _stages(fj)}
        if code not in (0, 1) or not fj:
            fits[v]["output"] = out
            say(f"{name}: fit {v} failed (exit {code})\n{out}")
            continue
        fits[v]["tir"] = str(out_dir / tyre_id / f"{tyre_id}.tir")
        if v == "default":
            seg = (fj.get("data_quality", {}).get("trailer") or {}).get("segmentation")
            rec["left_out"] = left_out(seg)
            rec["segmentation"] = None if seg is None else {
                "samples": seg["samples"], "in_sweeps": seg["in_sweeps"], "kept": seg["kept"],
                "p_levels": [lv["value"] for lv in seg["levels"].get("p", [])]}
            rec["_segments"] = seg["segments"] if seg else None
            rec["pressure_holdout"] = fj.get("pressure_holdout") or {}
    rec["fits"] = fits
    default_json = work / name / "fits" / "default" / tyre_id / "fit.json"
    if "default" not in fits and default_json.is_file():  # --reuse of a part: its levels
        seg = (json.loads(default_json.read_text()).get("data_quality", {}).get("trailer")
               or {}).get("segmentation")
        if seg:
            rec["segmentation"] = {"p_levels": [lv["value"] for lv in seg["levels"].get("p", [])]}
            rec["_segments"] = seg["segments"]

    # pressure levels and the samples' groups
    # the judge's own levels, from every loaded sample: not the segmentation's (the thing
    # judged), which can miss a level
    levels = pressure_levels(table["p"].to_numpy(float))
    rec["p_levels_Pa"] = levels
    level = nearest_level(table["p"].to_numpy(float), levels)

    # all-sample errors of every fit
    models = {v: predict(_tir_params(Path(f["tir"])), inputs) for v, f in fits.items()
              if "tir" in f}
    rec["all_samples"] = {v: {c: dataclasses.asdict(e)
                              for c, e in errors(inputs, m, level, ok).items()}
                          for v, m in models.items()}
    # Mx split by the kind of run: the Mx stage fits the freely rolling runs only (its MF
    # equation reads no Fx; a drive/brake run's Mx follows Fx and carries a zero of its own,
    # identify.fit.mf.stage_specs), so the all-sample Mx mixes the fitted runs with an
    # extrapolation the model cannot represent; a change of the fitted points can move the
    # two parts in opposite directions
    mx_kind = mx_by_run_kind(inputs, models, level, ok)
    if mx_kind:
        rec["mx_by_run_kind"] = mx_kind
    # the same on the samples of the default segmentation's sweeps (where a steady-state
    # model applies; the rest are warm-ups, transitions, partial sweeps)
    in_sweep = (sweep_rows(table, rec["_segments"]) >= 0) & ok if rec.get("_segments") \
        else None
    if in_sweep is not None and in_sweep.any():
        rec["samples"]["in_sweeps"] = int(in_sweep.sum())
        rec["sweep_samples"] = {v: {c: dataclasses.asdict(e)
                                    for c, e in errors(inputs, m, level, in_sweep).items()}
                                for v, m in models.items()}
    pub = {}
    for tir in published:
        try:
            pm = predict(_tir_params(tir), inputs)
        except Exception as exc:  # a file our model cannot evaluate: said, not fatal
            pub[tir.name] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        pub[tir.name] = {c: dataclasses.asdict(e) for c, e in errors(inputs, pm, level,
                                                                    ok).items()}
    if pub:
        rec["published"] = pub

    # held-out folds
    if len(levels) >= 2:
        folds = pressure_folds(table["p"].to_numpy(float), levels)
        rec["heldout_kind"] = "leave-one-pressure-out"
    else:
        segs = rec.get("_segments")
        if segs:
            sweeps = sweep_rows(table, segs)
        else:
            from identify.fit.mf.stage_data import sweep_ids
            sweeps = sweep_ids(table, float(mset.manifest.tyre.nominal_load_N))
        folds = sweep_folds(sweeps, n_folds, seed)
        rec["heldout_kind"] = f"held-out sweeps ({n_folds} seeded folds, seed {seed})"
    if max_folds is not None and len(folds) > max_folds:  # a seeded choice of them
        pick = np.random.default_rng(seed).choice(len(folds), max_folds, replace=False)
        rec["folds_left_out"] = [f.name for k, f in enumerate(folds) if k not in pick]
        folds = [folds[k] for k in sorted(pick)]
    rec.pop("_segments", None)
    if rec["heldout_kind"] == "leave-one-pressure-out":  # judged where the rest cover it
        cells = condition_cells(inputs)
        need = min(2, len(levels) - 1)  # two levels, or the one a two-level set keeps
        judged_rows = {f.name: covered(cells, f.rows, ok, level, need) for f in folds}
        rec["covered"] = {f.name: {"held_out": int((f.rows & ok).sum()),
                                   "covered": int(judged_rows[f.name].sum())} for f in folds}
    else:
        judged_rows = {f.name: f.rows & ok for f in folds}
    # the channels each fold excites (from the measured values alone: one rule for every
    # variant)
    shares = {f.name: {c: excitation(inputs[c].to_numpy(float), judged_rows[f.name], ok)
                       for c in CHANNELS if c in inputs.columns} for f in folds}
    judged = {name: {c: excited(x) for c, x in sh.items()} for name, sh in shares.items()}
    rec["excitation"] = {"share": EXCITED_SHARE, "folds": shares}
    held: dict[str, dict] = {}
    for v in models:
        per_fold = []
        for fold in folds:
            say(f"{name}: held-out fit {v}, without {fold.name} ({int(fold.rows.sum())} "
                "samples)")
            t0 = time.perf_counter()
            keep = ~fold.rows
            try:  # in memory: the fold's samples never measured, nothing written
                run = fit_measurements(
                    dataclasses.replace(mset, trailer=table[keep].reset_index(drop=True)),
                    settings=variant_settings(v))
            except Exception as exc:  # recorded: a fold the pipeline cannot fit is a finding
                per_fold.append({"fold": fold.name, "error": f"{type(exc).__name__}: {exc}"})
                continue
            params = {k: float(x) for k, x in run.tir_values.items()
                      if isinstance(x, (int, float))}
            pm = predict(params, inputs)
            rows = judged_rows[fold.name]
            one = np.zeros(len(table), int)
            per_fold.append({
                "fold": fold.name, "seconds": time.perf_counter() - t0,
                "samples": int(rows.sum()), "failed": list(run.failed),
                "heldout": {c: e.pooled_pct for c, e in errors(inputs, pm, one, rows).items()},
                "insample": {c: e.pooled_pct
                             for c, e in errors(inputs, models[v], one, rows).items()},
                "_pred": pm, "_rows": rows})
        held[v] = _aggregate(inputs, per_fold, judged)
    rec["heldout"] = held
    quiet = [c for c in CHANNELS if folds and not any(judged[f.name].get(c) for f in folds)]
    rec["verdict"] = verdict({v: {c: h["mean_pct"].get(c, math.nan) for c in CHANNELS}
                              for v, h in held.items()}, not_excited=quiet)
    return rec


def _aggregate(inputs: pd.DataFrame, per_fold: list[dict],
               judged: Mapping[str, Mapping[str, bool]]) -> dict:
    """Mean over the folds (and pooled over their held-out samples) of a variant's errors, per
    channel over the folds that excite it (``judged``: fold name -> channel -> excited)."""
    good = [f for f in per_fold if "heldout" in f]

    def on(c: str) -> list[dict]:  # the folds that judge channel c
        return [f for f in good if judged.get(f["fold"], {}).get(c) and c in f["heldout"]]

    mean = {c: float(np.mean([f["heldout"][c] for f in on(c)])) for c in CHANNELS if on(c)}
    mean_in = {c: float(np.mean([f["insample"][c] for f in on(c) if c in f["insample"]]))
               for c in mean if any(c in f["insample"] for f in on(c))}
    pooled = {}
    for c in mean:
        meas = np.concatenate([inputs[c].to_numpy(float)[f["_rows"]] for f in on(c)])
        mod = np.concatenate([f["_pred"][c][f["_rows"]] for f in on(c)])
        pooled[c] = rms_pct(meas, mod)
    for f in per_fold:
        f.pop("_pred", None)
        f.pop("_rows", None)
    return {"mean_pct": mean, "pooled_pct": pooled, "insample_mean_pct": mean_in,
            "folds": per_fold, "seconds": float(sum(f.get("seconds", 0.0) for f in per_fold))}


# ----- tables -----------------------------------------------------------------------------


def _f(x, fmt="{:.2f}") -> str:
    return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else fmt.format(x)


def tables(rec: dict) -> str:
    """Markdown tables of one set's record."""
    lines = [f"## {rec['set']}", ""]
    if "skipped" in rec:
        return "\n".join(lines + [f"skipped: {rec['skipped']}", ""])
    imp = rec.get("import", {})
    lines.append(f"import: exit {imp.get('exit')}, {_f(imp.get('seconds'), '{:.1f}')} s; "
                 f"samples loaded {rec.get('samples', {}).get('loaded')}, evaluated "
                 f"{rec.get('samples', {}).get('evaluated')}; pressure levels [kPa] "
                 + ", ".join(f"{p / 1e3:.1f}" for p in rec.get("p_levels_Pa", []))
                 + ("; the default segmentation's: " + ", ".join(
                     f"{p / 1e3:.1f}" for p in rec["segmentation"].get("p_levels", []))
                    if rec.get("segmentation") else ""))
    if "fits" not in rec:
        return "\n".join(lines + [""])
    lines += ["", "All samples (pooled % / thesis % = mean over pressure levels); the fit's wall "
                  "and CPU time (user + system; the wall time counts the other users of the "
                  "machine too):",
              "", "| variant | wall s | CPU s | failed | " + " | ".join(CHANNELS) + " |",
              "|---|---|---|---|" + "---|" * len(CHANNELS)]
    for v, f in rec["fits"].items():
        e = rec.get("all_samples", {}).get(v, {})
        cells = [f"{_f(e[c]['pooled_pct'])} / {_f(e[c]['thesis_pct'])}" if c in e else "-"
                 for c in CHANNELS]
        wall = _f(f["seconds"], "{:.1f}") + (" (report)" if f.get("report") else "")
        lines.append(f"| {v} | {wall} | {_f(f.get('cpu_seconds'), '{:.1f}')} | "
                     f"{len(f.get('failed', []))} | " + " | ".join(cells) + " |")
    for name, e in rec.get("published", {}).items():
        if "error" in e:
            lines.append(f"| published {name} | - | - | {e['error']} |")
            continue
        cells = [f"{_f(e[c]['pooled_pct'])} / {_f(e[c]['thesis_pct'])}" if c in e else "-"
                 for c in CHANNELS]
        lines.append(f"| published {name} | - | - | " + " | ".join(cells) + " |")
        d = rec.get("all_samples", {}).get("default", {})
        ratio = [f"{c} {d[c]['pooled_pct'] / e[c]['pooled_pct']:.2f}x" for c in CHANNELS
                 if c in d and c in e and e[c]["pooled_pct"]]
        lines.append(f"|  default / published (pooled) | | | {', '.join(ratio)} |")
    mk = rec.get("mx_by_run_kind", {})
    if mk:
        lines += ["", "Mx by kind of run (pooled % / thesis %): the freely rolling runs the Mx "
                      "stage fits, the other (drive/brake) runs it does not, and their share "
                      "of the all-sample squared Mx error:", "",
                  "| variant | Mx rolling runs | Mx other runs | other's share % |",
                  "|---|---|---|---|"]
        for v, e in mk.items():
            lines.append(f"| {v} | {_f(e['rolling']['pooled_pct'])} / "
                         f"{_f(e['rolling']['thesis_pct'])} | {_f(e['other']['pooled_pct'])} / "
                         f"{_f(e['other']['thesis_pct'])} | "
                         f"{_f(e['other_sse_share_pct'], '{:.0f}')} |")
    sw = rec.get("sweep_samples", {})
    if sw:
        lines += ["", f"The {rec['samples'].get('in_sweeps')} samples in the default "
                      "segmentation's sweeps only (pooled % / thesis %):", "",
                  "| variant | " + " | ".join(CHANNELS) + " |", "|---|" + "---|" * len(CHANNELS)]
        for v, e in sw.items():
            cells = [f"{_f(e[c]['pooled_pct'])} / {_f(e[c]['thesis_pct'])}" if c in e else "-"
                     for c in CHANNELS]
            lines.append(f"| {v} | " + " | ".join(cells) + " |")
    held = rec.get("heldout", {})
    if held:
        skipped = rec.get("folds_left_out")
        exc = rec.get("excitation", {})
        share = exc.get("folds", {})
        limit = exc.get("share", EXCITED_SHARE)

        def judged(fold: str, c: str) -> bool:  # a record without excitation judges all
            return fold not in share or excited(share[fold].get(c, math.nan), limit)

        lines += ["", f"Held-out error ({rec.get('heldout_kind')}"
                      + (f"; folds not run: {', '.join(skipped)}" if skipped else "")
                      + "): mean over the folds that excite the channel of the "
                      "pooled % on the held-out samples [pooled over their held-out samples] "
                      "(in-sample % of the full fit on the same samples); n.e.: no fold "
                      "excites it:", "",
                  "| variant | folds | " + " | ".join(CHANNELS) + " |",
                  "|---|---|" + "---|" * len(CHANNELS)]
        for v, h in held.items():
            nf = len([f for f in h["folds"] if "heldout" in f])
            cells = [f"{_f(h['mean_pct'].get(c))} [{_f(h['pooled_pct'].get(c))}] "
                     f"({_f(h['insample_mean_pct'].get(c))})" if c in h["mean_pct"]
                     else "n.e." for c in CHANNELS]
            lines.append(f"| {v} | {nf} | " + " | ".join(cells) + " |")
        cov = rec.get("covered")
        if cov:
            lines += ["", "Samples judged per fold (held out, of them at conditions the other "
                          "pressures cover at two levels or more): " + "; ".join(
                              f"{k} {x['held_out']}, {x['covered']}" for k, x in cov.items())]
        lines += ["", "Per fold, default (held-out % / in-sample %; n.e.: the fold does not "
                      f"excite the channel, its RMS there under {limit:g} of the set's, "
                      "the share in brackets; left out of the means and the verdict):", "",
                  "| fold | samples | " + " | ".join(CHANNELS) + " |",
                  "|---|---|" + "---|" * len(CHANNELS)]
        for f in held.get("default", {}).get("folds", []):
            if "heldout" not in f:
                lines.append(f"| {f['fold']} | - | {f.get('error')} |")
                continue
            cells = [f"{_f(f['heldout'].get(c))} / {_f(f['insample'].get(c))}"
                     if judged(f["fold"], c) else
                     f"n.e. ({_f(share[f['fold']].get(c), '{:.2f}')})" for c in CHANNELS]
            lines.append(f"| {f['fold']} | {f['samples']} | " + " | ".join(cells) + " |")
    vd = rec.get("verdict", {})
    if vd:
        parts = [f"{c}: not excited by any fold" if x.get("not_excited") else
                 f"{c}: {'ok' if x['ok'] else 'WORSE'} (best {x['best']}, default "
                 f"{x['ratio']:.3f}x)" for c, x in vd.items()]
        overall = all(x.get("ok", True) for x in vd.values())
        lines += ["", f"Verdict (default best or within {TIE:.2f}x of the best held-out "
                      f"error): {'YES' if overall else 'NO'}; " + "; ".join(parts)]
    lo = rec.get("left_out")
    if lo:
        seg = rec.get("segmentation") or {}
        lines += ["", f"Segmentation (default): {seg.get('samples')} samples, "
                      f"{seg.get('in_sweeps')} in sweeps, {seg.get('kept')} rows fitted; "
                      "left out:", ""]
        for why, n_seg, n in lo:
            lines.append(f"- {why}: {n} samples" + (f" in {n_seg} segment(s)" if n_seg >= 0
                                                     else ""))
    ph = rec.get("pressure_holdout") or {}
    if ph.get("levels"):
        stages = [s for s in ("Fx0", "Fy0", "Mz0", "Fx", "Fy", "Mz", "Mx")
                  if any(s in lv["heldout_pct"] for lv in ph["levels"])]
        lines += ["", f"The default fit's pressure page (MF stages refitted without each level, "
                      f"{ph.get('seconds', 0):.1f} s in all): in-sample % -> held-out % on the "
                      "level's fitted points", "",
                  "| p [bar] | " + " | ".join(stages) + " |", "|---|" + "---|" * len(stages)]
        for lv in ph["levels"]:
            cells = [f"{_f(lv['insample_pct'].get(s))} -> {_f(lv['heldout_pct'].get(s))}"
                     if s in lv["heldout_pct"] else "-" for s in stages]
            lines.append(f"| {lv['pressure_bar']:.2f} | " + " | ".join(cells) + " |")
    elif ph.get("skipped"):
        lines += ["", f"The default fit's pressure page: {ph['skipped']}"]
    st = rec["fits"].get("default", {}).get("stages", {})
    if st:
        lines += ["", "Default fit stages (status, fitted-point error %): "
                  + "; ".join(f"{k} {s['status']} {_f(s['error_pct'])}" for k, s in st.items())]
    return "\n".join(lines + [""])


def import_set(folder: Path, work: Path):
    """``mfid import`` the trailer files of ``folder`` into ``work``/<set>/measurement and
    load them: (wall s, the import's failure text or None, the measurement set, its loaded
    table, the model inputs, the rows the model can evaluate)."""
    from identify.io.folder import load_folder
    meas = work / folder.name / "measurement"
    wall, _cpu, code, out = mfid("import", *map(str, trailer_files(folder)), "--out",
                                 str(meas))
    if code != 0:
        return wall, f"import failed (exit {code}): {out[-300:]}", None, None, None, None
    mset = load_folder(meas)
    table = mset.trailer.reset_index(drop=True)
    inputs = model_inputs(table)
    return wall, None, mset, table, inputs, evaluable(inputs)


def sets_to_judge(dirs: Sequence[str] | None, prog: str) -> list[Path] | None:
    """:func:`find_sets`, said on the terminal: None (after a one-line error) when a named set
    is not a folder, an empty list (after a line saying so) when there is none to judge."""
    sets = find_sets(dirs)
    missing = [s for s in sets if not s.is_dir()]
    if missing:
        print(f"{prog}: not a folder: {', '.join(map(str, missing))}", file=sys.stderr)
        return None
    if not sets:
        print(f"{prog}: no real measurement sets at {REALDATA} (nothing to judge; "
              "--sets DIR names others)")
    return sets


def set_files(items: Sequence[str], flag: str, prog: str) -> dict[str, list[Path]] | None:
    """``SET=FILE.tir`` arguments as {set name: [files]}; None (after a one-line error on
    stderr) when one does not name an existing file."""
    out: dict[str, list[Path]] = {}
    for item in items:
        key, _, path = item.partition("=")
        if not path or not Path(path).is_file():
            print(f"{prog}: {flag} {item}: give SET=FILE.tir of an existing file",
                  file=sys.stderr)
            return None
        out.setdefault(key, []).append(Path(path))
    return out


def write_results(out: Path, name: str, markdown: str, doc: object, *,
                  show: bool = True) -> None:
    """Print ``markdown`` (with ``show``) and write it and ``doc`` as ``name``.md and
    ``name``.json into the results folder ``out``."""
    if show:
        print(markdown)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.md").write_text(markdown)
    (out / f"{name}.json").write_text(json.dumps(doc, indent=1, default=_json_default))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", nargs="+", metavar="DIR",
                    help="folders of trailer files to judge (default: every set under "
                         f"{REALDATA})")
    ap.add_argument("--quick", action="store_true",
                    help="default and --no-segment only, at most two held-out folds")
    ap.add_argument("--variants", nargs="+", choices=list(VARIANTS),
                    help="variants to run (default: all; the default pipeline always, except "
                         "with --reuse: a part of a former run)")
    ap.add_argument("--folds", type=int, default=3,
                    help="held-out sweep folds of a single-pressure set (default 3)")
    ap.add_argument("--seed", type=int, default=0,
                    help="seed of the held-out sweep folds and of the --max-folds choice")
    ap.add_argument("--max-folds", type=int, metavar="N",
                    help="hold out at most N folds per set (a seeded choice; --quick: 2; 0: "
                         "no held-out error)")
    ap.add_argument("--published", action="append", default=[], metavar="SET=TIR",
                    help="also evaluate this .tir on the samples of SET (repeatable)")
    ap.add_argument("--work", type=Path, help="scratch folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    ap.add_argument("--reuse", action="store_true",
                    help="with --work: take the import and the full fits a former run left "
                         "there (only the missing ones are made)")
    ap.add_argument("--out", type=Path, default=RESULTS,
                    help="folder of realdata.md and realdata.json (default bench/results)")
    a = ap.parse_args(argv)

    sets = sets_to_judge(a.sets, "realdata")
    if not sets:
        return 0 if sets is not None else 2
    variants = list(a.variants or (QUICK_VARIANTS if a.quick else VARIANTS))
    if "default" not in variants and not (a.reuse and a.variants):
        variants.insert(0, "default")
    published = set_files(a.published, "--published", "realdata")
    if published is None:
        return 2
    work = a.work or Path(tempfile.mkdtemp(prefix="mfid-realdata-"))
    work.mkdir(parents=True, exist_ok=True)

    def say(text: str) -> None:
        print(f"[{time.strftime('%H:%M:%S')}] {text}", flush=True)

    records = []
    try:
        for s in sets:
            rec = judge_set(s, work, variants, n_folds=a.folds, seed=a.seed,
                            max_folds=(a.max_folds if a.max_folds is not None
                                       else 2 if a.quick else None),
                            published=published.get(s.name, []), say=say, reuse=a.reuse)
            records.append(rec)
            print("\n" + tables(rec), flush=True)
    finally:
        if not a.keep and a.work is None:
            shutil.rmtree(work, ignore_errors=True)
    from identify.core.version import __version__ as version
    doc = {"mfid_version": version, "quick": a.quick, "variants": variants, "tie": TIE,
           "seed": a.seed, "sets": records}
    write_results(a.out, "realdata", "# Real-data benchmark\n\n"
                  + "\n".join(tables(r) for r in records), doc, show=False)
    print(f"wrote {a.out / 'realdata.md'} and {a.out / 'realdata.json'}")
    verdicts = [x["ok"] for r in records for x in r.get("verdict", {}).values() if "ok" in x]
    print("default best or tied on every set and channel: "
          + ("YES" if verdicts and all(verdicts) else "NO" if verdicts else "n/a"))
    return 0


def _json_default(x):
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)


if __name__ == "__main__":
    sys.exit(main())
