"""The singular value decomposition inside scipy's trust-region reflective solver, through a QR
decomposition first (:func:`qr_svd`, used by identify.fit.solve.engine.least_squares).

scipy's ``trf`` (``tr_solver="exact"``) takes the SVD U s V^T of its scaled n x k Jacobian
(augmented by k rows on bounds) at every iteration and uses U only as U^T f (f the residuals).
LAPACK's gesdd of a tall matrix first factors it as Q R, then decomposes R = U_R s V^T and
forms U = Q U_R explicitly (n x k: generating Q and a matrix product). Here U^T f is computed
as U_R^T (Q^T f) from the Householder reflectors instead, U never formed: the same s (gesdd
decomposes the same R), V and U^T f to round-off, without generating Q or the n x k product.
These SVDs are a sizeable share of the MF stages' solves (bench/fit_cost.py times them).

scipy's solver calls ``svd`` through its module's name; :func:`qr_svd` replaces that name for
the duration of a solve, only when the installed scipy's source uses U as U^T f alone
(:data:`PATCHABLE`), and only for matrices at least TALL times taller than wide.
"""
from __future__ import annotations

import contextlib
import inspect
import re
import threading

import numpy as np
import scipy.linalg
from scipy.linalg import lapack

try:  # scipy's private solver module: without it (another layout), no replacement
    from scipy.optimize._lsq import trf as _trf
except ImportError:  # pragma: no cover - other scipy versions
    _trf = None

__all__ = ["PATCHABLE", "TALL", "qr_svd", "tall_svd"]

TALL = 4
"""Rows per column from which the QR route is taken (gesdd itself takes it from ~1.8, but
its own choice is kept for near-square matrices)."""


def _patchable() -> bool:
    """The installed trf calls ``svd(..., full_matrices=False)`` twice and uses U only as
    ``U.T.dot(...)`` (scipy 1.10-1.17)."""
    if _trf is None or getattr(_trf, "svd", None) is not scipy.linalg.svd:
        return False
    try:
        src = inspect.getsource(_trf)
    except (OSError, TypeError):  # pragma: no cover - no source shipped
        return False
    return (src.count("svd(") == 2 and src.count("U, s, V = svd(") == 2
            and src.count("full_matrices=False)") == 2 and src.count("U.T.dot(") == 2
            and len(re.findall(r"\bU\b", src)) == 4)


PATCHABLE = _patchable()
"""Whether :func:`qr_svd` replaces trf's SVD (else it does nothing)."""


class _Transposed:
    """U^T of a tall matrix's thin SVD, U = Q U_R, held as Q's reflectors and U_R: only
    ``dot`` of a vector or matrix (U^T f)."""

    def __init__(self, qr: np.ndarray, tau: np.ndarray, ur: np.ndarray):
        self._qr, self._tau, self._ur = qr, tau, ur

    def dot(self, f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        c = f[:, None] if f.ndim == 1 else f
        ormqr, = lapack.get_lapack_funcs(("ormqr",), (self._qr,))
        lwork = int(ormqr("L", "T", self._qr, self._tau, c, -1)[1][0].real)
        qtf, _, info = ormqr("L", "T", self._qr, self._tau, c, max(lwork, 1))
        if info != 0:  # pragma: no cover - LAPACK argument errors only
            raise np.linalg.LinAlgError(f"ormqr failed (info {info})")
        k = self._ur.shape[0]
        out = self._ur.T @ qtf[:k]
        return out[:, 0] if f.ndim == 1 else out


class _LazyU:
    """The U of :func:`tall_svd`: only its transpose's ``dot`` is available."""

    def __init__(self, qr, tau, ur):
        self.T = _Transposed(qr, tau, ur)
        self.shape = (qr.shape[0], ur.shape[1])


def tall_svd(a: np.ndarray, full_matrices: bool = True, **kwargs):
    """scipy.linalg.svd, except for a thin SVD of a finite matrix at least TALL times taller
    than wide: (U, s, Vt) with U a stand-in that offers only ``U.T.dot(f)`` (see module)."""
    a = np.asarray(a)
    if (full_matrices or kwargs or a.ndim != 2 or a.dtype != np.float64
            or a.shape[0] < TALL * a.shape[1] or a.shape[1] == 0):
        return scipy.linalg.svd(a, full_matrices=full_matrices, **kwargs)
    a = np.asarray_chkfinite(a)  # as scipy.linalg.svd(check_finite=True)
    k = a.shape[1]
    geqrf, = lapack.get_lapack_funcs(("geqrf",), (a,))
    qr, tau, _, info = geqrf(a)
    if info != 0:  # pragma: no cover - LAPACK argument errors only
        raise np.linalg.LinAlgError(f"geqrf failed (info {info})")
    ur, s, vt = scipy.linalg.svd(np.triu(qr[:k]), full_matrices=False)
    return _LazyU(qr, tau, ur), s, vt


_LOCK = threading.Lock()
_DEPTH = [0]


@contextlib.contextmanager
def qr_svd():
    """Within this context scipy's trf takes its SVDs through :func:`tall_svd` (nothing when
    not :data:`PATCHABLE`). Nestable, and scipy's ``svd`` is back when the last context
    leaves, also on an exception. The name is the module's: while one thread is within, every
    trf solve of the process takes the QR route, those of other threads too (the same steps
    to round-off)."""
    if not PATCHABLE:
        yield
        return
    with _LOCK:
        _DEPTH[0] += 1
        if _DEPTH[0] == 1:
            _trf.svd = tall_svd
    try:
        yield
    finally:
        with _LOCK:
            _DEPTH[0] -= 1
            if _DEPTH[0] == 0:
                _trf.svd = scipy.linalg.svd
