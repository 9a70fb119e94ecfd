"""Compiled MF stage Jacobians kept on disk between runs, so that a later run neither traces
nor compiles them (identify.fit.mf.jacobian).

JAX's persistent compilation cache (``jax_compilation_cache_dir``) skips XLA's compile but is
keyed by the lowered program, so every run would still trace and lower each stage's function
in Python first; loading the executable stored here skips both, and costs a fraction of the
tracing. ``jax.export`` does not pay either: deserialising an exported stage and calling it
lowers and compiles a wrapper around it, which costs more than tracing. JAX's cache is not
switched on: an executable it supplies cannot be stored here (see :func:`store`), and with
this one it would serve only the few element-wise copies of the chunks.

An entry is keyed by everything that changes the traced program or the machine code: the
versions of JAX, jaxlib and mfid, a hash of the source files the trace runs through
(identify.model, identify.fit.mf.stage_specs and the Jacobian module), the stage, its
coefficients and held values, the structure, shapes and dtypes of the arguments (one chunk,
identify.fit.mf.jacobian.CHUNK: the same for every data size), the backend, the CPU and
``XLA_FLAGS``. An entry starts with its key in full and is used only if that matches; an
entry that does not load (corrupt, truncated, another JAX) is ignored and replaced by a
freshly traced one; one neither written nor loaded for UNUSED_DAYS is deleted when another is
written. Entries live in ``stages/`` of the JAX cache directory (:func:`directory`:
``MFID_JAX_CACHE``, default ``~/.cache/mfid/jax`` or under ``XDG_CACHE_HOME``; empty: no cache),
never beside the data. Loading an executable runs machine code from the cache directory (as
JAX's compilation cache, used there before, does): it must be the user's own.
"""
from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import json
import os
import platform
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from identify.core.atomic import atomic_write_bytes
from identify.core.errors import InputError
from identify.core.version import __version__

__all__ = ["CACHE_ENV", "UNUSED_DAYS", "directory", "program_key", "load", "store", "prune"]

CACHE_ENV = "MFID_JAX_CACHE"
MAGIC = b"mfid-stage-executable 1\n"
"""First line of an entry (its format); the key's JSON, the payload's SHA-256 (hex) and the
payload (the serialized executable) follow."""
UNUSED_DAYS = 30.0
"""Entries neither written nor loaded for this long are deleted (:func:`prune`)."""
_SOURCES = ("identify/model", "identify/fit/mf/stage_specs.py", "identify/fit/mf/jacobian.py")
"""The code a stage's trace runs through (relative to the package's parent directory)."""


def directory() -> str:
    """The JAX cache directory ('' for none): ``MFID_JAX_CACHE`` if set (empty switches the
    caches off), else ``mfid/jax`` in ``XDG_CACHE_HOME`` or ``~/.cache``."""
    return os.environ.get(CACHE_ENV, os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "mfid", "jax"))


@functools.cache
def _source_hash() -> str:
    """SHA-256 of the traced code's source files (module docstring), in a fixed order."""
    root = Path(__file__).resolve().parents[3]
    digest = hashlib.sha256()
    for rel in _SOURCES:
        path = root / rel
        for f in sorted(path.rglob("*.py")) if path.is_dir() else [path]:
            digest.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes())
    return digest.hexdigest()


@functools.cache
def _machine(jax) -> dict[str, str]:
    """The backend and CPU a compiled executable is specific to."""
    device = jax.devices()[0]
    flags = ""
    try:
        with open("/proc/cpuinfo") as f:
            flags = next((line for line in f if line.startswith(("flags", "Features"))), "")
    except OSError:  # not Linux: the architecture and processor name stand for the CPU
        flags = platform.processor()
    return {"platform": device.platform, "platform_version": device.client.platform_version,
            "device_kind": device.device_kind, "machine": platform.machine(),
            "cpu_flags": hashlib.sha256(flags.encode()).hexdigest()}


@functools.cache
def _jaxlib_version() -> str:
    return importlib.metadata.version("jaxlib")


def _leaf(x) -> list:
    """Shape, dtype and whether a Python scalar (JAX's weak type) of one argument leaf."""
    dtype = x.dtype if hasattr(x, "dtype") else np.result_type(x)
    weak = getattr(x, "weak_type", isinstance(x, (bool, int, float, complex)))
    return [list(np.shape(x)), np.dtype(dtype).str, bool(weak)]


def program_key(jax, stage: str, coefficients: Sequence[str], others: Sequence[str],
                args: tuple) -> str:
    """The key of the compiled Jacobian of ``stage`` for arguments like ``args`` (JSON text;
    see module)."""
    leaves, tree = jax.tree_util.tree_flatten((args, {}))
    return json.dumps({
        "jax": jax.__version__, "jaxlib": _jaxlib_version(), "mfid": __version__,
        "source": _source_hash(), "machine": _machine(jax),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "x64": bool(jax.config.jax_enable_x64), "stage": stage,
        "coefficients": list(coefficients), "others": list(others), "tree": str(tree),
        "leaves": [_leaf(x) for x in leaves]}, sort_keys=True)


def _path(key: str) -> Path | None:
    where = directory()
    if not where:
        return None
    return Path(where) / "stages" / (hashlib.sha256(key.encode()).hexdigest()[:40] + ".bin")


def _head(key: str, payload: bytes) -> bytes:
    """An entry's header: format, key, SHA-256 of the payload. A damaged payload is never
    handed to XLA, which does not reject every damaged executable: a flipped byte may fail to
    parse, but it may as well load, run and give other Jacobians without an error."""
    return MAGIC + key.encode() + b"\n" + hashlib.sha256(payload).hexdigest().encode() + b"\n"


def load(jax, key: str, args: tuple) -> Callable | None:
    """The stored executable for ``key`` (called like the jitted function with ``args``), or
    None: no cache, no entry, or one that does not match or load (see module)."""
    path = _path(key)
    if path is None:
        return None
    try:
        blob = path.read_bytes()
    except OSError:
        return None
    size = len(_head(key, b""))  # the header's length does not depend on the payload
    payload = blob[size:]
    if blob[:size] != _head(key, payload):
        return None
    try:
        fn = jax.experimental.serialize_executable.deserialize_and_load(
            payload, jax.tree_util.tree_structure((args, {})), jax.tree_util.tree_structure(0))
    except Exception:  # noqa: BLE001 - any failure to load an entry means: trace afresh
        return None
    try:  # used now: kept by prune
        os.utime(path)
    except OSError:
        pass
    return fn


def store(jax, key: str, compiled, args: tuple) -> bool:
    """Write ``compiled`` (jit(...).lower(*args).compile()) as the entry of ``key`` (atomically:
    a reader sees the old entry, the new one or none) and :func:`prune` the others; False when
    there is no cache, it is not writable or the executable cannot be serialized."""
    path = _path(key)
    if path is None:
        return False
    try:
        payload, in_tree, out_tree = jax.experimental.serialize_executable.serialize(compiled)
    except (ValueError, NotImplementedError, TypeError):
        return False
    if (in_tree != jax.tree_util.tree_structure((args, {}))
            or out_tree != jax.tree_util.tree_structure(0)):
        return False  # load could not rebuild it
    # only a copy that runs and gives the same numbers: one that JAX loaded from its own
    # compilation cache (JAX_COMPILATION_CACHE_DIR) serializes without its code on the CPU and
    # fails when run ("Function ... not found", jax 0.10.2)
    try:
        copy = jax.experimental.serialize_executable.deserialize_and_load(
            payload, in_tree, out_tree)
        if not np.array_equal(np.asarray(copy(*args)), np.asarray(compiled(*args)),
                              equal_nan=True):
            return False
    except Exception:  # noqa: BLE001
        return False
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, _head(key, payload) + payload)
    except (OSError, InputError):  # a cache that cannot take it is no error
        return False
    prune(path.parent)
    return True


def prune(where: Path, days: float = UNUSED_DAYS) -> None:
    """Delete the entries of ``where`` not written or loaded for ``days`` (those of older mfid,
    JAX or model code, whose keys no run asks for again), and the partial writes as old (the
    ``.tmp`` files of :func:`store` in a process killed while writing)."""
    limit = time.time() - days * 86400.0
    for entry in [*where.glob("*.bin"), *where.glob("*.bin*.tmp")]:
        try:
            if entry.stat().st_mtime < limit:
                entry.unlink()
        except OSError:  # gone meanwhile, or not ours to delete
            pass
