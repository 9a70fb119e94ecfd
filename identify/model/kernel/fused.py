"""Compiled forward model (numba, vectorised): the fast twin of :mod:`identify.model.evaluate`.

The pure-numpy path is the reference; this kernel evaluates the same equations in compiled
loops that LLVM vectorises (AVX2/AVX-512): every equation is branch-free
(:mod:`~identify.model.kernel.state`, :mod:`~identify.model.kernel.forces`,
:mod:`~identify.model.kernel.moments`, :mod:`~identify.model.kernel.vertical`) and the
transcendental functions are vectorisable polynomials (:mod:`~identify.model.kernel.vector_math`)
instead of scalar libm calls. Points are processed in blocks of :data:`BLOCK` so a block's
intermediate values stay in cache between its passes (forces and moments, then the Re/omega
fixed point, then the deflection). Tested against the numpy path to 1e-10 relative for every
output, useMode and FITTYP.

Entry points
------------
``evaluate_fused(P, fz, kappa, alpha, gamma, vx, p, omega, phit, mode)``
    every output, the same dict as ``evaluate``.
``evaluate_outputs(P, ("Fy",), fz, kappa, alpha, gamma, vx, p, mode=211)``
    only the named outputs, through the smallest compiled loop that yields them: ``Fx``,
    ``Fy``, or ``Fx, Fy, Mz`` (with ``t, Mzr, Kya, Kxk, mux, muy``) skip the moments, the
    rolling radius and the deflection; anything else runs the full kernel. For fits that
    evaluate one force at many points.

:data:`ENGINE` names the path that runs: ``"numba-simd"``, or ``"numpy"`` when numba cannot be
imported (then both entry points call the numpy reference, correct and slower).
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from os import cpu_count

import numpy as np

from identify.model.evaluate import evaluate, frame_inputs, output_frame
from identify.model.modes import UseMode

try:  # numba is a dependency; keep the model importable (on the numpy path) without it
    import numba

    from identify.model.kernel.blocks import BLOCK, forces_block, full_block
    from identify.model.kernel.state import KERNEL_KEYS, KernelParams, kernel_params
    ENGINE = "numba-simd"
except ImportError:  # pragma: no cover
    numba = None
    ENGINE = "numpy"

__all__ = ["BLOCK", "ENGINE", "FORCE_COLUMNS", "KERNEL_COLUMNS", "KERNEL_KEYS", "KernelParams",
           "evaluate_fused", "evaluate_fused_frame", "evaluate_outputs", "kernel_params"]

KERNEL_COLUMNS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz", "Re", "rho", "2a", "t", "mux", "muy",
                  "omega", "Rl", "2b", "Mzr", "Cx", "Cy", "Cz", "Kya", "sigmax", "sigmay", "Kxk",
                  "kappa_out", "alpha_out", "p_used", "phit_out", "Rl_converged")
"""Rows of the full kernel's output matrix."""
FORCE_COLUMNS = ("Fx", "Fy", "Mz", "t", "Mzr", "Kya", "Kxk", "mux", "muy")
"""Rows of the slip-force kernel's output matrix (what forces_block computes)."""
_FORCE_SETS = {0: ("Fx",), 1: ("Fy",), 2: FORCE_COLUMNS}  # what = 0, 1, 2 in forces_block


def _columns(P, fz, kappa, alpha, gamma, vx, p, omega, phit):
    fz = np.ascontiguousarray(np.atleast_1d(np.asarray(fz, dtype=float)).ravel())
    n = fz.size

    def col(x, default):
        if x is None:
            return np.full(n, default)
        a = np.asarray(x, dtype=float)
        return np.ascontiguousarray(np.broadcast_to(a, (n,)) if a.ndim == 0 else a.ravel())

    p_arr = col(p, 0.0)
    if p is None or np.sum(p_arr) == 0:
        p_arr = np.full(n, float(P["INFLPRES"]))
    om = col(omega, 0.0)
    has_omega = omega is not None and bool(np.sum(om) != 0)
    return (fz, col(kappa, 0.0), col(alpha, 0.0), col(gamma, 0.0), col(vx, 0.0), p_arr,
            col(phit, 0.0), om), has_omega


def _run(fn, n: int, args_before, arrays, args_after, out, threads: bool) -> None:
    """Call ``fn(*args_before, *arrays, *args_after, out)``, on one thread per core if asked
    (contiguous slices of whole blocks; the kernel releases the GIL)."""
    workers = max(1, min(cpu_count() or 1, n // (4 * BLOCK))) if threads else 1
    if workers == 1:
        fn(*args_before, *arrays, *args_after, out)
        return
    edges = (np.linspace(0, n // BLOCK, workers + 1).astype(int) * BLOCK)
    edges[-1] = n

    def work(k):
        sl = slice(edges[k], edges[k + 1])
        fn(*args_before, *(a[sl] for a in arrays), *args_after, out[:, sl])

    with ThreadPoolExecutor(workers) as pool:
        list(pool.map(work, range(workers)))


def _check(P: Mapping[str, float], mode) -> UseMode:
    if int(P["FITTYP"]) not in (61, 62):
        raise ValueError(f"FITTYP {int(P['FITTYP'])} is not supported (61 or 62)")
    return mode if isinstance(mode, UseMode) else UseMode.from_code(mode)


def evaluate_fused(P: Mapping[str, float], fz, kappa, alpha, gamma, vx, p=None, omega=None,
                   phit=None, mode: int | UseMode = 111,
                   threads: bool = False) -> dict[str, np.ndarray]:
    """Every output at every point: the compiled twin of ``evaluate.evaluate`` (default
    solver options: Re iterated per point, MF 6.2 loaded radius solved to round-off).

    Same arguments and the same returned dict of arrays (each a contiguous row of one output
    matrix). ``threads=True`` spreads the points over one thread per core; points are
    independent, so the result is identical.
    """
    um = _check(P, mode)
    if ENGINE == "numpy":  # pragma: no cover
        return evaluate(P, fz, kappa, alpha, gamma, vx, p=p, omega=omega, phit=phit, mode=um)
    arrays, has_omega = _columns(P, fz, kappa, alpha, gamma, vx, p, omega, phit)
    n = arrays[0].size
    out = np.empty((len(KERNEL_COLUMNS), n))
    _run(full_block, n, (kernel_params(P),), arrays, (has_omega, um.limits, um.alpha_star),
         out, threads)
    result = {name: out[j] for j, name in enumerate(KERNEL_COLUMNS)}
    result["Rl_converged"] = result["Rl_converged"] == 1.0
    failed = np.flatnonzero(~result["Rl_converged"])
    if failed.size:
        # MF 6.2 points where the secant found no root (or one at Rl <= 0): where the starting
        # pair (0.95 R0, R0) lies outside the root's basin the iterates jump around and
        # round-off decides where they end; the numpy reference decides those (few) points, so
        # both paths agree on them
        # (one extra point with omega = 1 keeps "omega given" when the subset's omega sum to 0)
        sub = [np.append(a[failed], a[failed[0]]) for a in arrays]
        sub[7][-1] = 1.0
        ref = evaluate(P, *sub[:6], omega=sub[7] if has_omega else None, phit=sub[6], mode=um)
        for name in KERNEL_COLUMNS:
            result[name][failed] = ref[name][:-1]
    return result


def evaluate_outputs(P: Mapping[str, float], outputs: Iterable[str], fz, kappa, alpha, gamma,
                     vx, p=None, omega=None, phit=None, mode: int | UseMode = 111,
                     threads: bool = False) -> dict[str, np.ndarray]:
    """Only the named outputs (names of ``evaluate.OUTPUT_COLUMNS``), computed as cheaply as
    the kernel allows; the values equal ``evaluate_fused``'s.

    Parameters
    ----------
    outputs : iterable of str
        e.g. ``("Fy",)`` for a lateral-force fit, ``("Fx", "Fy", "Mz")`` for the combined
        forces. ``Fx``, ``Fy`` and any of :data:`FORCE_COLUMNS` avoid the moments Mx/My, the
        Re/omega iteration and the deflection.
    fz, kappa, alpha, gamma, vx, p, omega, phit, mode, threads
        As ``evaluate_fused``.

    Returns
    -------
    dict[str, ndarray]
        One array per requested name.
    """
    wanted = tuple(dict.fromkeys(outputs))
    um = _check(P, mode)
    what = next((w for w, cols in _FORCE_SETS.items() if set(wanted) <= set(cols)), None)
    if what is None or ENGINE == "numpy":
        full = evaluate_fused(P, fz, kappa, alpha, gamma, vx, p=p, omega=omega, phit=phit,
                              mode=um, threads=threads)
        missing = [w for w in wanted if w not in full]
        if missing:
            raise KeyError(f"unknown output(s): {', '.join(missing)}")
        return {w: full[w] for w in wanted}
    arrays, _ = _columns(P, fz, kappa, alpha, gamma, vx, p, omega, phit)
    n = arrays[0].size
    cols = _FORCE_SETS[what]
    out = np.empty((len(cols), n))
    _run(forces_block, n, (kernel_params(P),), arrays[:6],
         (um.limits, um.alpha_star, what), out, threads)
    return {w: out[cols.index(w)] for w in wanted}


def evaluate_fused_frame(P: Mapping[str, float], points, mode: int | UseMode = 111):
    """Compiled twin of :func:`identify.model.evaluate.evaluate_frame`."""
    return output_frame(points, evaluate_fused(P, **frame_inputs(points), mode=mode))
