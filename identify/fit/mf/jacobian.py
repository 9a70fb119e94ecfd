"""Exact derivatives of the MF stage models by forward-mode automatic differentiation (JAX).

The stage equations are the model's own (identify.model, written for any array module ``xp``)
evaluated by :func:`identify.fit.mf.stage_specs.stage_predict` with ``xp = jax.numpy``; JAX's
``jacfwd`` differentiates them with respect to every coefficient of the stage at once and XLA
compiles the result (``jit``). The Jacobian is the FitProblem's ``jacobian`` hook
(identify.fit.solve.problem.JacobianFn), so the least-squares solver, the covariance, the polish
gradient, the identifiability screen and discovery all use it.

JAX is an optional extra (``pip install mfid[fast]``). Without it, or with the environment
variable ``MFID_JACOBIAN=fd``, :func:`stage_jacobian` returns None and the fits use finite
differences (the same optimum, at more model evaluations). With JAX, a stage whose
points x (coefficients + 1) are fewer than MIN_WORK keeps finite differences too, since the
compile would cost more than it saves; ``MFID_JACOBIAN=jax`` uses JAX for every stage.
Each stage's compiled function is kept on disk (identify.fit.mf.jax_cache; ``MFID_JAX_CACHE``,
default ``~/.cache/mfid/jax``; empty: none), which a later run loads without tracing or
compiling, at a fraction of the tracing's cost. Without an entry a stage is traced and
compiled once, and stored.

Cost (bench/fit_jacobian.py, bench/fit_cost.py --jacobian): the points are evaluated in chunks of
CHUNK (the last one padded), so that one compiled function per stage serves every data size
(the subsample search and the full-data polish, every refit, every pass): one trace and
compile per stage (then stored), then a few evaluations' time per Jacobian, where two-point
finite differences cost 1 + free coefficients evaluations.
"""
from __future__ import annotations

import dataclasses
import functools
import os
from collections.abc import Callable, Mapping

import numpy as np

from identify.fit.mf import jax_cache as mf_jax_cache
from identify.fit.mf.stage_specs import (
    STAGES,
    names_read,
    stage_inputs,
    stage_predict,
    subset_state,
)
from identify.model.lateral import CombinedLateral, PureLateral
from identify.model.state import OperatingState

__all__ = ["CHUNK", "ENV", "MIN_WORK", "NUMPY_ONLY", "available", "use_exact", "stage_jacobian"]

CHUNK = 2048
"""Points per compiled Jacobian call (the MF search's subsample, identify.fit.mf.search.SUBSAMPLE,
is one chunk). Smaller chunks pad less (the last chunk is padded to CHUNK: 6418 points cost
8192 with chunks of 4096, 6144 + 2048 with 2048), larger ones make fewer calls (each call has
a fixed dispatch cost). A chunk equal to the subsample gives the search one call per Jacobian
and the solves on all points little padding (bench/fit_cost.py --jacobian jax times the
stages)."""
NUMPY_ONLY = ("vertical",)
"""Stages whose equations are numpy only: finite differences always (the MF 6.2 loaded radius
is a secant solve with a data-dependent number of steps; the stage has seven coefficients)."""
ENV = "MFID_JACOBIAN"
"""Environment variable: ``fd`` forces finite differences even where JAX is installed, ``jax``
exact derivatives for every stage, ``auto`` (default) exact ones where they pay (MIN_WORK)."""
MIN_WORK = 30_000
"""Points x (the stage's coefficients + 1) from which a stage uses the exact Jacobian in the
``auto`` mode. A two-point finite-difference Jacobian costs k + 1 model evaluations of all
points, so its cost grows with this product; the exact one costs the stage's tracing once (or
loading its stored executable, identify.fit.mf.jax_cache) and then little per call. Below
the limit the finite differences are cheap enough that the tracing would not pay off within a
fit's Jacobians; above it the exact Jacobian saves most of the model evaluations.
bench/fit_cost.py --jacobian fd / jax / auto compares a folder's stages all three ways."""


@functools.cache
def _jax():
    """(jax, jax.numpy) with 64-bit floats, or None when JAX is not installed.

    Imported on first use, not with this module: importing JAX takes a sizeable fraction of a
    second, which every ``mfid`` command would pay otherwise.
    """
    # one XLA thread (a chunk is small; a second thread contends with the BLAS and the other
    # processes of a batch); a user's own XLA_FLAGS win
    os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                                       "intra_op_parallelism_threads=1")
    try:
        import jax
        import jax.experimental.serialize_executable  # noqa: F401 (mf_jax_cache uses it)
        import jax.numpy as jnp
    except ImportError:
        return None
    jax.config.update("jax_enable_x64", True)
    for cls, meta in ((OperatingState, ("mode",)), (PureLateral, ()), (CombinedLateral, ())):
        names = [f.name for f in dataclasses.fields(cls)]
        jax.tree_util.register_dataclass(
            cls, data_fields=[n for n in names if n not in meta], meta_fields=list(meta))
    return jax, jnp


def available() -> bool:
    """JAX is installed and not switched off (``MFID_JACOBIAN=fd``)."""
    return os.environ.get(ENV, "").lower() != "fd" and _jax() is not None


def use_exact(n_points: int, n_coefficients: int) -> bool:
    """Whether a stage of ``n_points`` points and ``n_coefficients`` candidate coefficients
    uses the exact Jacobian (see ENV and MIN_WORK). JAX is imported only when the answer
    depends on it being installed: a run whose stages are all below MIN_WORK does not pay the
    JAX import."""
    if (os.environ.get(ENV, "").lower() != "jax"
            and n_points * (n_coefficients + 1) < MIN_WORK):
        return False
    return available()


PURE_FY0 = "Fy0 pure slip"
"""The program of the Fy0 stage whose points are all at kappa == 0 (stage_predict's
``pure_slip``): its own compiled function and cache entry."""


@functools.cache
def _compiled(stage: str, coefficients: tuple[str, ...], others: tuple[str, ...]):
    """jit(jacfwd) of the stage prediction with respect to ``coefficients`` (theta), the other
    parameters a vector in ``others`` order; one per stage and parameter set per process (JAX
    compiles it again only for a new chunk structure). ``stage`` PURE_FY0: Fy0 at kappa == 0."""
    jax, jnp = _jax()
    pure = stage == PURE_FY0
    name = "Fy0" if pure else stage

    def predict(theta, fixed, s, inputs):
        P = dict(zip(others, fixed))
        P.update(zip(coefficients, theta))
        return stage_predict(name, P, s, inputs, xp=jnp, pure_slip=pure)

    return jax.jit(jax.jacfwd(predict))


_EXECUTABLES: dict[str, Callable] = {}
"""This process's compiled stage Jacobians by identify.fit.mf.jax_cache.program_key."""


def _executable(stage: str, coefficients: tuple[str, ...], others: tuple[str, ...],
                args: tuple) -> Callable:
    """The compiled :func:`_compiled` for arguments like ``args`` (theta, fixed, one chunk's
    state and inputs): this process's, else the disk cache's (identify.fit.mf.jax_cache), else
    traced and compiled now and stored there."""
    jax, _ = _jax()
    key = mf_jax_cache.program_key(jax, stage, coefficients, others, args)
    fn = _EXECUTABLES.get(key)
    if fn is None:
        fn = mf_jax_cache.load(jax, key, args)
        if fn is not None:
            try:  # an entry that loads but does not run (see mf_jax_cache) is traced afresh
                jax.block_until_ready(fn(*args))
            except Exception:  # noqa: BLE001
                fn = None
        if fn is None:
            fn = _compiled(stage, coefficients, others).lower(*args).compile()
            mf_jax_cache.store(jax, key, fn, args)
        _EXECUTABLES[key] = fn
    return fn


def _read_others(stage: str, base: Mapping[str, float], s: OperatingState,
                 omega: np.ndarray | None) -> tuple[str, ...]:
    """The names of ``base`` besides the stage's coefficients that its equations read
    (mf_stage_defs.names_read on a few points; Fy0 under JAX evaluates the combined-slip
    expression at every point, so the Fy stage's reads are added), in ``base`` order."""
    few = np.arange(min(int(s.fz.size), 8))
    sub = subset_state(s, few)
    w = None if omega is None else np.asarray(omega)[few]
    read = names_read(stage, base, sub, w)
    if stage == "Fy0":
        read |= names_read("Fy", base, sub, w)
    own = set(STAGES[stage].coefficients)
    return tuple(k for k in base if k not in own and k in read)


def _runs(cols: list[int]) -> list[tuple[int, int, int]]:
    """The column indices ``cols`` as runs of consecutive columns, (first, stop, position in
    ``cols``) each: copying a chunk's columns by slices is a few block copies, where indexing
    them gathers element by element, per chunk and Jacobian."""
    runs: list[tuple[int, int, int]] = []
    for j, c in enumerate(cols):
        if runs and runs[-1][1] == c:
            runs[-1] = (runs[-1][0], c + 1, runs[-1][2])
        else:
            runs.append((c, c + 1, j))
    return runs


def _chunk(tree, index: np.ndarray, n: int):
    """The points ``index`` of every length-``n`` array leaf of ``tree`` (scalars as they are),
    as numpy arrays: the compiled function takes them as they are at a small cost per call,
    less over the few calls a chunk serves than copying the chunk to the device
    (jax.device_put); a jnp.asarray per leaf would dispatch once per leaf and compile for the
    scalars."""
    jax, _ = _jax()

    def take(leaf):
        a = np.asarray(leaf)
        return a[..., index] if a.ndim and a.shape[-1] == n else leaf
    return jax.tree_util.tree_map(take, tree)


def stage_jacobian(stage: str, base: Mapping[str, float], s: OperatingState,
                   omega: np.ndarray | None = None, *, exact: bool | None = None
                   ) -> Callable[[Mapping[str, float], tuple[str, ...]], np.ndarray] | None:
    """The exact Jacobian of the stage model (identify.fit.mf.stage_specs.stage_model) at the
    points ``s``, or None for finite differences (see module).

    Parameters
    ----------
    stage : str
    base : mapping
        Every .tir value (held values); the stage's own coefficients come from each call's
        ``values``.
    s : OperatingState
        The stage's points (useMode 211).
    omega : ndarray [rad/s], optional
        Wheel speed (geometry stage).
    exact : bool, optional
        True: the exact Jacobian whenever JAX is available (a subsample of a stage that has
        it); False: None; default :func:`use_exact` for the points and the stage's
        coefficients.

    Returns
    -------
    callable or None
        jacobian(values, names) -> d prediction / d names, (points, len(names)) [unit of the
        quantity per unit of each coefficient]; ``names`` must be coefficients of the stage.
    """
    coefficients = STAGES[stage].coefficients
    n = int(s.fz.size)
    if stage in NUMPY_ONLY:
        return None
    if exact is None:
        exact = use_exact(n, len(coefficients))
    if not exact or not available():
        return None
    # the held values the equations read, not all ~260 (a slice per value in the traced
    # function would cost every Jacobian call for values no equation reads); every value
    # if that set misses one
    others = _read_others(stage, base, s, omega)
    fn = None
    fixed = np.array([float(base[k]) for k in others])
    inputs = stage_inputs(stage, base, s, omega)
    starts = range(0, n, CHUNK)
    # each chunk's points, taken once (the last chunk padded with its first point, whose rows
    # are dropped)
    chunks = []
    for a in starts:
        index = np.arange(a, min(a + CHUNK, n))
        pad = np.concatenate([index, np.full(CHUNK - index.size, a)])
        chunks.append((index.size, _chunk(s, pad, n), _chunk(inputs, pad, n)))
    position = {c: j for j, c in enumerate(coefficients)}
    # Fy0 with every point at kappa == 0 (the pure-slip sweeps): the pure-slip program
    program = PURE_FY0 if stage == "Fy0" and not np.any(s.kappa != 0) else stage

    def call(theta, sc, ic):
        nonlocal others, fn, fixed
        if fn is None:  # every chunk has the same shapes: one executable
            try:
                fn = _executable(program, coefficients, others, (theta, fixed, sc, ic))
            except KeyError:  # a held value the set above missed (raised while tracing)
                every = tuple(k for k in base if k not in set(coefficients))
                if others == every:
                    raise
                others, fixed = every, np.array([float(base[k]) for k in every])
                fn = _executable(program, coefficients, others, (theta, fixed, sc, ic))
        return fn(theta, fixed, sc, ic)

    def jacobian(values: Mapping[str, float], names: tuple[str, ...]) -> np.ndarray:
        unknown = [m for m in names if m not in position]
        if unknown:
            raise ValueError(f"{', '.join(unknown)}: not coefficients of the MF {stage} stage")
        theta = np.array([float(values.get(c, base[c])) for c in coefficients])
        runs = _runs([position[m] for m in names])
        out = np.empty((n, len(names)))
        for a, (size, sc, ic) in zip(starts, chunks):
            J = np.asarray(call(theta, sc, ic))
            for src, stop, dst in runs:
                out[a:a + size, dst:dst + stop - src] = J[:size, src:stop]
        return out
    return jacobian
