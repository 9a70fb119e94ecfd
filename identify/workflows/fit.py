"""The whole fit of one measurement folder: load -> extract -> fit -> outputs.

``fit_folder`` runs the MF stages on trailer data (when present; the CFz relation that supplies
the vertical stiffness of their geometry stage is fitted before them), then every relation of the
plan whose characteristics are present (extracted from raw Flatplank runs and/or given as
tables), optionally MCMC, and writes ``fits/<tyre id>/`` as in docs/fit-directory.md. Every file
is written to a temporary name and renamed; the measurement folder is only read.
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from contextlib import ExitStack
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from identify.core.atomic import atomic_path
from identify.core.errors import InputError
from identify.core.names import name_problem
from identify.core.progress import Progress
from identify.extract import extract_folder
from identify.fit.coverage import coverage_text, mf_coverage
from identify.fit.every_sample import every_sample, segment_kinds
from identify.fit.identifiability import assess
from identify.fit.mcmc.chains import ChainSession, run_mcmc
from identify.fit.mcmc.steps import ChainProgress
from identify.fit.mf.constraints import violations
from identify.fit.mf.pressure_holdout import pressure_holdout
from identify.fit.mf.profile import profile_intervals
from identify.fit.mf.stage_specs import STAGES
from identify.fit.mf.stages import fit_mf, stage_mcmc
from identify.fit.mf.uncertainty import propagate
from identify.fit.relations.plan import PLAN, RELATION_NAMES
from identify.fit.relations.problems import Context
from identify.fit.result import FitResult
from identify.fit.run import FitRun, FitSettings, Provenance, failures
from identify.fit.sources import DEFAULT, FITTED, KeySource
from identify.io.fitdir import rows_of, write_fit_dir
from identify.io.folder import MeasurementSet, load_folder
from identify.io.output_guard import check_fit_outputs, measurement_inputs
from identify.model.parameters import defaults, spec
from identify.workflows import tir_assembly as TA
from identify.workflows.sweep_bins import mf_table, segment_settings
from identify.workflows.trailer_prep import prepare_trailer

__all__ = ["GEOMETRY_INPUTS", "FitRun", "FitSettings", "fit_folder", "fit_measurements",
           "only_names"]

ChainProgressFn = Callable[[str, ChainProgress], None]
"""Called with a chain's name (``MF_Fy0``, ``CFy_relaxation``) and where it stands."""

GEOMETRY_INPUTS = ("VERTICAL_STIFFNESS", "PFZ1")
""".tir keys the MF geometry stage holds: a plan entry writing them is fitted before the MF
stages."""


def _say(progress: Progress | None, text: str) -> None:
    if progress is not None:
        progress(text)


class _Chains:
    """MCMC runs of one fit_folder call, their shared time budget and their chain files.

    The chains are queued while the fits run (``queue``) and sampled once every fit is done
    (``run_all``), cheapest first (points x free coefficients squared), so that the time
    budget of the whole MCMC run (``FitSettings.mcmc_budget_s``) can be shared out: each chain
    may use the budget left divided by the chains left, so a chain that converges early leaves
    its unused time to the ones after it; the chains the budget stopped are then continued
    (not restarted) with what is left.

    Each chain is written to a temporary name next to fits/<id>/mcmc/<name>.h5 and renamed
    only when the whole fit has been written (``with`` block left without an exception); an
    exception (KeyboardInterrupt, the CLI's SIGTERM included) removes every temporary chain,
    and the mcmc/ folder if this run created it, so an interrupted run leaves no chain file.
    """

    def __init__(self, settings: FitSettings, out_root, progress: ChainProgressFn | None):
        self.settings = settings
        self.folder = Path(out_root) / "mcmc"  # fits/<id>/mcmc once the id is known
        self.progress = progress
        self.stack = ExitStack()
        self.made: list[Path] = []
        self.jobs: list[tuple[float, int, str, str, Callable[..., FitResult]]] = []

    def __enter__(self) -> _Chains:
        self.stack.__enter__()
        return self

    def __exit__(self, *exc) -> bool:
        try:
            return self.stack.__exit__(*exc)
        finally:
            if exc[0] is not None:
                for d in reversed(self.made):  # only folders this run created, if empty
                    try:
                        d.rmdir()
                    except OSError:
                        pass

    def _tmp(self, name: str) -> tuple[Path, Path] | tuple[None, None]:
        if not self.settings.save_chains:
            return None, None
        for d in (self.folder.parent.parent, self.folder.parent, self.folder):
            if not d.exists():
                d.mkdir()
                self.made.append(d)
        final = self.folder / f"{name}.h5"
        tmp = self.stack.enter_context(atomic_path(final))
        tmp.unlink()  # emcee's HDF backend creates the file
        return final, tmp

    def queue(self, index: int, name: str, title: str, fit: FitResult,
              sample: Callable[..., FitResult]) -> None:
        """Sample ``results[index]`` (the least-squares ``fit``) later with ``sample(
        chain_file=..., progress=..., max_steps=..., budget=..., seed=..., ar1=...)``;
        ``title`` is the progress line."""
        cost = float(fit.n_points) * max(len(fit.free), 1) ** 2
        self.jobs.append((cost, index, name, title, sample))

    def run_all(self, results: list[FitResult], progress: Progress | None) -> None:
        """Run the queued chains, cheapest first, each with its share of the budget left; then
        continue the chains the budget stopped, in the same order, with the time the others
        left (again shared out). Sets the ``mcmc`` summary of their results (naming the
        final chain file)."""
        s = self.settings
        t0 = time.perf_counter()
        jobs = sorted(self.jobs, key=lambda j: j[0])  # stable: plan order among equals
        files = {name: self._tmp(name) for _c, _i, name, _t, _s in jobs}
        sessions = {name: ChainSession() for _c, _i, name, _t, _s in jobs}

        def sample_each(todo: list, continued: bool) -> None:
            for k, (_cost, index, name, title, sample) in enumerate(todo):
                share = None
                if s.mcmc_budget_s is not None:  # the budget left over the chains left
                    left_s = max(s.mcmc_budget_s - (time.perf_counter() - t0), 0.0)
                    share = left_s / (len(todo) - k)
                    if continued and share < 1.0:
                        return
                _say(progress, f"{title} (continued with the time the other chains left)"
                     if continued else title)
                final, tmp = files[name]
                chain_progress = (None if self.progress is None
                                  else partial(self.progress, name))
                mc = sample(chain_file=tmp, progress=chain_progress,
                            max_steps=s.mcmc_max_steps, budget=share, seed=s.seed,
                            ar1=s.mcmc_ar1, session=sessions[name]).mcmc
                if final is not None:
                    mc = dataclasses.replace(mc, chain_file=str(final))
                results[index] = dataclasses.replace(results[index], mcmc=mc)

        sample_each(jobs, continued=False)
        if s.mcmc_budget_s is not None:
            sample_each([j for j in jobs if results[j[1]].mcmc.stopped == "budget"],
                        continued=True)
        self.jobs.clear()


def _mf_trailer(td, fnomin: float, settings: FitSettings,
                progress: Progress | None) -> pd.DataFrame:
    """The trailer table the MF stages fit: the session logs segmented (and binned) by
    identify.workflows.trailer_prep as they are; the other runs segmented when they hold a
    warm-up, their dense sweeps binned (identify.workflows.sweep_bins)."""
    done = td.table["run"].astype(str).isin(td.segmented_runs).to_numpy()
    table, notes = mf_table(td.table[~done], fnomin, segment=settings.segment,
                            settings=segment_settings(settings))
    for note in notes:
        _say(progress, note)
    return pd.concat([td.table[done], table], ignore_index=True) if done.any() else table


def _base_tir(mset, fittyp: int) -> dict:
    """.tir values before fitting: MFeval defaults with the folder's nominal conditions."""
    t = defaults()
    tyre = mset.manifest.tyre
    t["FITTYP"] = float(fittyp)
    t["FNOMIN"] = float(tyre.nominal_load_N)
    t["NOMPRES"] = t["INFLPRES"] = float(tyre.nominal_pressure_Pa)
    if tyre.unloaded_radius_m and math.isfinite(tyre.unloaded_radius_m):
        t["UNLOADED_RADIUS"] = float(tyre.unloaded_radius_m)
    return t


def _numeric(t: dict) -> dict[str, float]:
    return {k: float(v) for k, v in t.items() if isinstance(v, (int, float))}


def _context(tyre, tir: dict, **kwargs) -> Context:
    """The relations' Context of ``tyre`` (nominal load and pressure) at the values ``tir``."""
    return Context(fz0=float(tyre.nominal_load_N), p0_bar=float(tyre.nominal_pressure_Pa) / 1e5,
                   tir=_numeric(tir), **kwargs)


def _characteristics(mset, progress) -> tuple[pd.DataFrame, tuple, dict | None]:
    frames = []
    flags: tuple = ()
    extraction = None
    if mset.flatplank is not None and len(mset.flatplank):
        _say(progress, "extract: characteristics from raw Flatplank runs")
        ex = extract_folder(mset)
        frames.append(ex.characteristics)
        flags = tuple(ex.flags)
        extraction = ex.to_dict()
    if mset.characteristics is not None and len(mset.characteristics):
        frames.append(mset.characteristics)
    if not frames:
        return pd.DataFrame(columns=["quantity", "pi_bar", "Fz_N", "value", "unit"]), flags, \
            extraction
    chars = pd.concat(frames, ignore_index=True)
    if "p_Pa" not in chars or chars["p_Pa"].isna().any():
        chars["p_Pa"] = chars["pi_bar"] * 1e5
    return chars, flags, extraction


VERTICAL_FROM_FLATPLANK = ("the vertical stiffness comes from the Flatplank CFz relation "
                           "(measured at standstill)")
"""Why the MF vertical stage (the loaded radius of the trailer data) is skipped when the
Flatplank data gave the CFz relation: that is the stiffness VERTICAL_STIFFNESS, Q_FZ2, PFZ1
define, measured directly, and the geometry stage held it already."""


def _stiffness_measured(coverage: tuple) -> tuple:
    """``coverage`` with the MF vertical stage skipped (VERTICAL_FROM_FLATPLANK)."""
    return tuple(dataclasses.replace(c, skipped=VERTICAL_FROM_FLATPLANK, identifiable=(),
                                     not_identifiable={})
                 if c.stage == "vertical" and not c.skipped else c for c in coverage)


def _skipped_sources(coverage) -> dict[str, KeySource]:
    """The coefficients of every skipped MF stage: kept at their start value, and why."""
    out = {}
    for c in coverage:
        if c.skipped:
            for n in (n for n in STAGES[c.stage].coefficients if spec(n).fit_default_vary):
                out[n] = KeySource(DEFAULT, f"MF/{c.stage} skipped: {c.skipped}")
    return out


def _csv_rows(result: FitResult, problem) -> pd.DataFrame:
    n = result.n_points
    extra = getattr(problem, "extra", {}) or {}
    cols = {k: np.asarray(extra.get(k, np.full(n, np.nan)), dtype=float)
            for k in ("Fz_N", "gamma_deg", "alpha_rad", "kappa", "Vx_mps")}
    quantity = extra.get("quantity", result.relation)
    return pd.DataFrame({"relation": result.relation, "form": result.form,
                         "quantity": quantity, "unit": problem.unit,
                         "pi_bar": result.pressure_bar, **cols,
                         "measured": result.measured, "model": result.predicted})


def fit_folder(source: str | Path, *, out_root: str | Path = "fits",
               settings: FitSettings = FitSettings(), progress: Progress | None = None,
               nominal_pressure_Pa: float | None = None, nominal_load_N: float | None = None,
               command: str = "", chain_progress: ChainProgressFn | None = None,
               check_outputs: Callable[[str], None] | None = None,
               pool: Executor | None = None) -> FitRun:
    """Fit a measurement folder (or a single characteristics CSV) and write the outputs.

    ``check_outputs`` is called with the tyre id as soon as it is known, before any fit: the
    caller's check of the paths it will write (identify.io.output_guard.check_fit_outputs), so that
    a bad output path fails before the work, not after it; by default the fit directory is
    checked against ``source`` (never inside the measurement folder).

    ``progress`` is called with a line per step; ``chain_progress`` with each MCMC chain's name
    and a :class:`identify.fit.mcmc.steps.ChainProgress` about once a second while it runs and when
    it stops.

    ``pool``: worker processes (identify.core.workers.process_pool) for the parts that do not
    depend on each other (the MF stages' profile intervals); the same results as without
    (one process, the default).

    Returns
    -------
    FitRun
        What was fitted and written (``fit_dir`` set). A fit that did not converge or whose
        constraints are infeasible is listed in ``run.failed`` (the outputs are written all
        the same, marked as failed); the CLI exits 1 when it is not empty.

    Raises
    ------
    InputError
        The folder or file is malformed, or an output cannot be written (exit 2 from the
        CLI).
    """
    with _Chains(settings, out_root, chain_progress) as chains, _one_blas_thread():
        run = _fit_folder(source, settings, progress, nominal_pressure_Pa, nominal_load_N,
                          command, chains, out_root=out_root, check_outputs=check_outputs,
                          pool=pool)
        _say(progress, f"write: {Path(out_root) / run.tyre.id} ({len(run.points)} points)")
        return write_fit_dir(run, Path(out_root) / run.tyre.id, points=run.points,
                             extraction=run.extraction)


def fit_measurements(source: str | Path | MeasurementSet, *,
                     settings: FitSettings = FitSettings(), progress: Progress | None = None,
                     nominal_pressure_Pa: float | None = None,
                     nominal_load_N: float | None = None, command: str = "",
                     chain_progress: ChainProgressFn | None = None) -> FitRun:
    """Fit a measurement folder, a characteristics CSV or a loaded ``MeasurementSet`` in
    memory: the same fit as :func:`fit_folder`, nothing written.

    The run holds what a fit directory would: its results (each with its measured and
    model points), the .tir values, ``points`` (the rows of measured_vs_model.csv) and
    ``extraction``; :func:`identify.io.fitdir.write_fit_dir` writes them. MCMC chains are
    summarised in the results but their samples are not kept (``save_chains`` is off).
    """
    settings = dataclasses.replace(settings, save_chains=False)
    with _Chains(settings, ".", chain_progress) as chains, _one_blas_thread():
        return _fit_folder(source, settings, progress, nominal_pressure_Pa, nominal_load_N,
                           command, chains, out_root=None)


def _one_blas_thread():
    """One BLAS thread for the whole fit: its linear algebra is on small dense matrices
    (Jacobians of a few thousand rows and tens of columns), where a second thread gains
    nothing and, on a machine busy with other work, makes each decomposition wait for a
    core: the profile intervals' SVDs and the jackknife's eigendecompositions ran two orders
    of magnitude slower with two threads than with one on a loaded two-core machine."""
    return threadpool_limits(limits=1, user_api="blas")


def _fit_folder(source, settings: FitSettings, progress: Progress | None,
                nominal_pressure_Pa, nominal_load_N, command: str, chains: _Chains, *,
                out_root, check_outputs: Callable[[str], None] | None = None,
                pool: Executor | None = None) -> FitRun:
    unknown = [n for n in settings.only if n not in RELATION_NAMES]
    if unknown:
        raise InputError(None, f"unknown relation(s) {', '.join(unknown)}; choose from "
                               f"{', '.join(RELATION_NAMES)}", key="--only")
    overrides = TA.form_overrides(settings.forms)
    hold = TA.hold_names(settings.hold)
    if isinstance(source, MeasurementSet):
        mset = source
    else:
        _say(progress, f"load: {source}")
        mset = load_folder(source, nominal_pressure_Pa=nominal_pressure_Pa,
                           nominal_load_N=nominal_load_N)
    tyre = mset.manifest.tyre
    if name_problem(tyre.id):  # load_folder refuses it; a second lock on the output paths
        raise InputError(mset.manifest.path, name_problem(tyre.id), key="tyre.id")
    if out_root is not None:  # written: checked before any work (the API's default too)
        if check_outputs is None:
            check_outputs = partial(check_fit_outputs, out_root, None,
                                    inputs=measurement_inputs(mset.path))
        check_outputs(tyre.id)
        chains.folder = Path(out_root) / tyre.id / "mcmc"
    chars, flags, extraction = _characteristics(mset, progress)
    tir = _base_tir(mset, settings.fittyp)
    key_sources: dict[str, KeySource] = TA.apply_tyre(tir, tyre)
    results: list[FitResult] = []
    rows: list[pd.DataFrame] = []
    wanted = (lambda name: not settings.only or name in settings.only)

    # the MF geometry stage holds the vertical stiffness Cz' = VERTICAL_STIFFNESS (1 + PFZ1 dpi)
    # of the Re equation (trailer files carry no deflection): fit the relation that supplies it
    # (CFz, Flatplank) first; the plan loop below reuses that fit
    prefit: dict[tuple[str, str], TA.EntryFit] = {}
    if mset.trailer is not None and len(mset.trailer) and wanted("MF"):
        ctx0 = _context(tyre, tir)
        for entry in PLAN:
            if not wanted(entry.relation) or not set(entry.writes) & set(GEOMETRY_INPUTS):
                continue
            if entry.build(chars, ctx0) is None:
                continue
            _say(progress, f"fit: {entry.relation} [{entry.form}] (vertical stiffness for the "
                           "MF geometry stage)")
            ef = TA.fit_entry(entry, chars, ctx0, seed=settings.seed, hold=hold)
            prefit[(entry.relation, entry.form)] = ef
            if ef.result.converged:
                tir.update({k: ef.result.parameters[k] for k in entry.writes
                            if k in ef.result.parameters})

    coverage: tuple = ()
    holdout: dict = {}  # the pressure page's record (identify.fit.mf.pressure_holdout)
    seg_kinds = None  # per loaded trailer row, what the segmentation made of it
    fitted_mf = False  # the MF stages ran: the written limits must meet their conditions
    quality: dict = {"warnings": [w.to_dict() for w in mset.warnings]} if mset.warnings else {}
    if mset.trailer is not None and len(mset.trailer) and wanted("MF"):
        td = prepare_trailer(mset, segment_settings(settings), segment=settings.segment)
        if td.segmentation is not None:
            sg = td.segmentation
            _say(progress, f"segment: {', '.join(td.segmented_runs)}: {sg.kept} of "
                           f"{sg.samples} samples kept in {sg.counts().get('sweep', 0)} sweeps")
        if td.mz_turnaround:
            _say(progress, f"turn-arounds: Mz of {td.mz_turnaround} samples at slip-angle "
                           "turn-arounds left out (the rig's steering transient)")
        quality["trailer"] = td.to_dict()
        seg_kinds = segment_kinds(mset.trailer, td.segmentation.segments
                                  if td.segmentation is not None else None, td.segmented_runs)
        trailer = _mf_trailer(td, float(tyre.nominal_load_N), settings, progress)
        coverage = mf_coverage(trailer, float(tyre.nominal_load_N), unavailable=td.unavailable)
        if any(ef.result.converged for ef in prefit.values()):
            coverage = _stiffness_measured(coverage)
        for line in coverage_text(coverage):
            _say(progress, f"coverage: {line}")
        key_sources.update(_skipped_sources(coverage))
        stages = [c.stage for c in coverage if c.fitted]
        if stages:
            _say(progress, "fit: Magic Formula stages on trailer data")
            # the written limits span the characteristics' points too: hold the MF validity
            # conditions over those ranges as well
            reach = TA.relation_reach(chars, _context(tyre, tir), wanted)
            mf = fit_mf(trailer, _numeric(tir), seed=settings.seed, fittyp=settings.fittyp,
                        stages=stages, passes=settings.mf_passes, reach=reach,
                        progress=progress)
            _say(progress, "MF standard errors: delete-one-sweep jackknife, the earlier "
                           "stages' uncertainty included")
            mf = propagate(trailer, mf)
            _say(progress, "MF 95 % intervals: profiles of the objective (refits with each "
                           "coefficient held)")
            mf = profile_intervals(trailer, mf, progress, pool=pool)
            if settings.pressure_holdout:
                holdout = pressure_holdout(trailer, mf, progress=progress, pool=pool).to_dict()
            fitted_mf = True
            for r in mf.results:
                if settings.mcmc:
                    chains.queue(len(results), f"MF_{r.form}", f"mcmc: MF [{r.form}]", r,
                                 partial(stage_mcmc, trailer, mf, r.form,
                                         reparam=settings.mcmc_reparam))
                results.append(assess(r))
            key_sources.update(TA.mf_sources(mf.results, mf.held))
            tir.update(mf.params)
            rows.append(mf.measured_vs_model())

    ctx = _context(tyre, tir, kya_from_tir=any(
        key_sources.get(k, KeySource.default()).kind == FITTED for k in ("PKY1", "PKY2")))
    choices = []
    for relation in TA.relations_in_plan_order():
        if not wanted(relation):
            continue
        fitted: dict[str, TA.EntryFit] = {}
        for entry in (e for e in PLAN if e.relation == relation):
            if (entry.relation, entry.form) in prefit:
                ef = prefit[(entry.relation, entry.form)]
            else:
                if entry.build(chars, ctx) is None:
                    continue
                _say(progress, f"fit: {entry.relation} [{entry.form}]")
                ef = TA.fit_entry(entry, chars, ctx, seed=settings.seed, hold=hold)
            problem, result = ef.problem, ef.result
            if settings.mcmc:
                chains.queue(len(results), f"{entry.relation}_{entry.form}",
                             f"mcmc: {entry.relation} [{entry.form}]", result,
                             partial(run_mcmc, problem, result))
            fitted[entry.form] = ef
            results.append(result)
            rows.append(_csv_rows(result, problem))
        choice = TA.write_relation(relation, fitted, chars, ctx, tir, key_sources,
                                   override=overrides.get(relation))
        if choice is not None:
            choices.append(choice)
        ctx = dataclasses.replace(ctx, tir=_numeric(tir))  # later relations see the .tir
    if not results:
        raise InputError(mset.path, _nothing_to_fit(mset, coverage, bool(settings.only)))
    chains.run_all(results, progress)  # after every fit: the budget is shared between them
    points = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    TA.apply_limits(tir, key_sources, points)
    broken = _broken_validity(tir, points) if fitted_mf else ()
    every = {}
    if fitted_mf:  # the .tir's slip coefficients are the trailer's, not defaults
        _say(progress, "the .tir against every loaded trailer sample")
        every = every_sample(_numeric(tir), mset.trailer, seg_kinds).to_dict()
    run = FitRun(tyre=tyre, provenance=Provenance.now(command=command, seed=settings.seed,
                                                     settings=settings,
                                                     checksums=mset.checksums,
                                                     folder=mset.path),
                 results=tuple(results),
                 key_sources=TA.complete(key_sources, settings.fittyp),
                 fittyp=settings.fittyp, tir_name=f"{tyre.id}.tir",
                 flags=tuple(dict(f) for f in flags), failed=failures(results) + broken,
                 tir_values=tir, form_choices=tuple(choices), coverage=coverage,
                 data_quality=quality, pressure_holdout=holdout, every_sample=every,
                 points=points,
                 extraction=extraction)
    return dataclasses.replace(run, results=tuple(
        dataclasses.replace(r, points=rows_of(points, r)) for r in run.results))


def _nothing_to_fit(mset, coverage: tuple, only: bool) -> str:
    """Why a folder gave no fit, naming what is too little and where: each trailer run's file
    and samples, and the first stages' reasons for being skipped."""
    known = f"no characteristics of a known quantity{' for --only' if only else ''}"
    trailer = mset.trailer
    if trailer is None or not len(trailer):
        return f"nothing to fit: no trailer data and {known}"
    files = {r.id: r.file for r in mset.manifest.runs}
    counts = trailer.groupby("run", sort=False).size()
    runs = ", ".join(f"{files.get(run, run)} ({n} sample(s))" for run, n in counts.items())
    why = "; ".join(f"{c.stage}: {c.skipped}" for c in coverage if c.skipped)
    shown = why if len(why) <= 300 else why[:297] + "..."
    return (f"nothing to fit: too little trailer data for any Magic Formula stage in {runs}"
            + (f" ({shown})" if shown else "") + f", and {known}")


def _broken_validity(tir: dict, points: pd.DataFrame) -> tuple[str, ...]:
    """``tir[validity]: ...`` for every MF validity condition the written values break within
    the written limits, at the pressures of the fitted points (identify.fit.mf.constraints.
    violations): the stages hold them over the same ranges, so a line here means a stage
    whose constraints could not be met."""
    pressures = np.unique(pd.to_numeric(points["pi_bar"], errors="coerce").dropna()) * 1e5
    params = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    params.update(_numeric(tir))
    return tuple(f"tir[validity]: {line} within the written limits"
                 for line in violations(params, pressures))


def only_names(values: Sequence[str]) -> tuple[str, ...]:
    """Split repeated/comma-separated --only values."""
    return tuple(n.strip() for v in values for n in v.split(",") if n.strip())
