"""Sign changes of coefficients that leave every output of the model unchanged.

Several Magic Formula terms see a coefficient only through an even function (cos(atan(B x)),
a square) or a product of odd ones (D sin(C atan(B x))). Changing the sign of the coefficients
of one :class:`Mirror` together gives a second parameter set that predicts bit for bit what
the first predicts (``tests/unit/test_model_symmetries.py`` checks each on the golden test set,
every output, combined slip, camber and pressure). Data cannot tell the two apart, so:

- a fit that ends at one is not "another minimum" away from the other;
- a fitted value is compared with the image of the truth that shares its signs;
- the fit reports the image nearest its start, so the written .tir keeps the signs of the
  .tir it started from (identify.fit.mf.minima.sign_images).

The parameter table's bounds keep one sign of several of these (PKY1 and PKY4 by magnitude;
RBX1, RBX2, RBY1, RBY2 and BREFF >= 0); they are listed because they are facts of the
equations, and the fit only takes an image inside the bounds.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Mirror", "MIRRORS", "sign_patterns", "nearest_image", "aligned"]


@dataclass(frozen=True)
class Mirror:
    """Coefficients whose signs change together without changing any output.

    Attributes
    ----------
    names : tuple[str, ...]
        The coefficients (MFeval names).
    term : str
        The term of the model that makes the change exact (docs/model.md).
    """

    names: tuple[str, ...]
    term: str


MIRRORS: tuple[Mirror, ...] = (
    Mirror(("QBZ9", "QBZ10"),
           "Mzr = Dr cos(atan(Br alpha_r)), Br = QBZ9 LKY/LMUY + QBZ10 By Cy"),
    Mirror(("RVY4",), "D_Vyk carries cos(atan(RVY4 alpha))"),
    Mirror(("RVY5", "RVY1", "RVY2", "RVY3"),
           "S_Vyk = D_Vyk sin(RVY5 atan(RVY6 kappa)), D_Vyk linear in RVY1..3"),
    Mirror(("RVY6", "RVY1", "RVY2", "RVY3"),
           "S_Vyk = D_Vyk sin(RVY5 atan(RVY6 kappa)), D_Vyk linear in RVY1..3"),
    Mirror(("QSX5",), "Mx: cos(QSX5 atan((QSX6 Fz/Fz0)^2))"),
    Mirror(("QSX6",), "Mx: cos(QSX5 atan((QSX6 Fz/Fz0)^2))"),
    Mirror(("QSX8", "QSX9"), "Mx: QSX8 atan(QSX9 Fy/Fz0)"),
    Mirror(("QSX4", "QSX7", "QSX8"), "Mx: QSX4 sin(QSX7 gamma + QSX8 atan(QSX9 Fy/Fz0))"),
    Mirror(("QSX10", "QSX11"), "Mx: QSX10 atan(QSX11 Fz/Fz0) gamma"),
    Mirror(("Q_FCX",), "vertical load: (Q_FCX Fx/Fz0)^2"),
    Mirror(("Q_FCY",), "vertical load: (Q_FCY Fy/Fz0)^2"),
    # kept to one sign by the parameter table's bounds
    Mirror(("PKY1", "PKY4"), "Kya = PKY1 Fz0 ... sin(PKY4 atan(Fz / (PKY2 ... Fz0)))"),
    Mirror(("PKY1", "PKY2", "PKY5"), "Kya = PKY1 Fz0 ... sin(PKY4 atan(Fz / ((PKY2 + PKY5 "
                                     "gamma^2) ... Fz0)))"),
    Mirror(("RBX1", "RBX3"), "Gxa even in Bxa = (RBX1 + RBX3 gamma^2) cos(atan(RBX2 kappa))"),
    Mirror(("RBX2",), "Bxa carries cos(atan(RBX2 kappa))"),
    Mirror(("RBY1", "RBY4"), "Gyk even in Byk = (RBY1 + RBY4 gamma^2) cos(atan(RBY2 (alpha - "
                             "RBY3)))"),
    Mirror(("RBY2",), "Byk carries cos(atan(RBY2 (alpha - RBY3)))"),
    Mirror(("DREFF", "BREFF"), "Re: DREFF atan(BREFF rho_d)"),
)
"""Every exact sign symmetry of the steady-state model (MF 6.1 and 6.2)."""


def sign_patterns(names: Sequence[str], held: Mapping[str, float] | None = None) -> np.ndarray:
    """The sign changes over ``names`` that leave the model unchanged.

    A mirror applies when each of its coefficients is in ``names`` or is held at 0 in
    ``held`` (0 is its own image); a mirror with no coefficient in ``names`` changes nothing
    here and is left out.

    Returns
    -------
    ndarray, shape (m, len(names))
        Rows of +1/-1, every product of the applicable mirrors, the first row all +1
        (the identity); m is a power of 2.
    """
    names = list(names)
    held = held or {}
    rows = {tuple([1.0] * len(names))}
    for m in MIRRORS:
        inside = [n for n in m.names if n in names]
        if not inside or not all(n in names or held.get(n) == 0.0 for n in m.names):
            continue
        g = np.ones(len(names))
        g[[names.index(n) for n in inside]] = -1.0
        rows |= {tuple(np.multiply(r, g)) for r in rows}
    return np.array(sorted(rows, reverse=True), dtype=float).reshape(len(rows), len(names))


def nearest_image(x: np.ndarray, ref: np.ndarray, patterns: np.ndarray,
                  scale: np.ndarray | None = None) -> np.ndarray:
    """The image s * x (s a row of ``patterns``) nearest ``ref``.

    Parameters
    ----------
    x, ref : ndarray, shape (k,)
        Values of the same k coefficients.
    patterns : ndarray, shape (m, k)
        :func:`sign_patterns` of those coefficients.
    scale : ndarray, shape (k,), optional
        Distance unit per coefficient; default max(|ref|, 1e-3).

    Returns
    -------
    ndarray
        The nearest image; ties go to the earliest row (``x`` itself first).
    """
    x = np.asarray(x, dtype=float)
    ref = np.asarray(ref, dtype=float)
    if len(patterns) <= 1:
        return x
    unit = np.maximum(np.abs(ref), 1e-3) if scale is None else np.asarray(scale, dtype=float)
    with np.errstate(over="ignore"):  # a runaway value is infinitely far: the answer meant
        d = np.sum(((patterns * x - ref) / unit) ** 2, axis=1)
    return patterns[int(np.argmin(d))] * x


def aligned(values: Mapping[str, float], ref: Mapping[str, float], names: Sequence[str],
            scale: Mapping[str, float] | None = None) -> dict[str, float]:
    """``values`` (a whole parameter set, e.g. a truth) as its image nearest ``ref`` in
    ``names`` (e.g. a fit's free coefficients), distance in units of ``scale`` (e.g. their
    standard errors; default max(|ref|, 1e-3)). Every coefficient of a mirror that touches
    ``names`` changes sign with it, in ``names`` or not, so the result is the same tyre."""
    touched = [n for m in MIRRORS if any(k in names for k in m.names) for n in m.names]
    every = [n for n in dict.fromkeys([*names, *touched]) if n in values]
    patterns = sign_patterns(every)
    if len(patterns) <= 1:
        return dict(values)
    x = np.array([float(values[n]) for n in every])
    compared = np.array([n in names and n in ref for n in every])
    r = np.array([float(ref[n]) if c else 0.0 for n, c in zip(every, compared)])
    unit = np.maximum(np.abs(r), 1e-3)
    if scale is not None:
        given = np.array([float(scale.get(n, 1.0)) for n in every])
        unit = np.where(np.isfinite(given) & (given > 0), given, unit)
    # a coefficient not compared counts for nothing: an infinite unit
    image = nearest_image(x, r, patterns, np.where(compared, unit, np.inf))
    return {**values, **{n: float(v) for n, v in zip(every, image)}}
