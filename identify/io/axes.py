"""Axis systems of force and moment data, converted to ISO-W (= TYDEX W, the model's axes).

ISO-W (docs/model.md, section 1): origin at the contact point, x forward along the line
where the wheel plane meets the road, z up (normal to the road), y = z x x to the left.

SAE (x forward, y right, z down) is ISO-W turned half a turn about x. Vector components along y
and z change sign, so Fy, Fz, My and Mz flip while Fx and Mx keep their sign; the slip angle is
measured about z and flips too; kappa keeps its sign (driving positive in both). Inclination is
a rotation about the shared x axis, so its sign would be kept; but rigs define camber
differently (top outward, per vehicle side), so ``gamma`` is passed through unchanged and a rig
with another convention must say so through its own data (check the camber thrust sign).

TYDEX-C has its origin at the wheel centre: x as in W, y along the spin axis, z in the wheel
plane. With gamma a rotation about x, the C unit vectors expressed in W are
``eyC = (0, cos g, sin g)`` and ``ezC = (0, -sin g, cos g)``, and the wheel centre sits at
``d = r_l * ezC`` from the contact point (r_l the loaded radius). The same force system seen in
W axes at the contact point is therefore ``F_W = R F_C`` and ``M_W = R M_C + d x F_W``::

    Fx = FxC                          Mx = MxC - r_l*FyC
    Fy = FyC cos g - FzC sin g        My = MyC cos g - MzC sin g + r_l*FxC cos g
    Fz = FyC sin g + FzC cos g        Mz = MyC sin g + MzC cos g + r_l*FxC sin g

These are exactly the Flatplank hub transform of docs/procedures.md with FyC = -Ky, FzC = Kz,
MxC = -Tx, MyC = 0, MzC = Tz (a lateral force at the road, +y, gives MxC = MxW + r_l*Fy at the
hub, hence the minus sign in Mx).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["AXES", "axes_name", "sae_to_iso_w", "c_to_w", "to_iso_w"]

#: Axis systems the loaders accept.
AXES = ("ISO-W", "SAE", "TYDEX-C")


def axes_name(text: object) -> str | None:
    """The axis system ``text`` names, spelled as in :data:`AXES` (case and surrounding
    spaces ignored, as for units: ``"iso-w"`` -> ``"ISO-W"``), or None for another text."""
    if not isinstance(text, str):
        return None
    return next((a for a in AXES if a.lower() == text.strip().lower()), None)

_SAE_FLIP = ("Fy", "Fz", "My", "Mz", "alpha")
_FM = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


def sae_to_iso_w(frame: pd.DataFrame) -> pd.DataFrame:
    """A copy of a tidy table with SAE signs turned to ISO-W.

    Flips Fy, Fz, My, Mz and alpha; keeps Fx, Mx, kappa and gamma (see the module notes).
    Columns that are absent are skipped.
    """
    out = frame.copy(deep=False)  # copy-on-write: assigning columns leaves ``frame`` as it is
    for col in _SAE_FLIP:
        if col in out.columns:
            out[col] = -out[col]
    return out


def c_to_w(FxC, FyC, FzC, MxC, MyC, MzC, gamma, loaded_radius) -> dict[str, np.ndarray]:
    """Wheel-centre forces and moments (TYDEX C axes) to the contact point in ISO-W axes.

    Parameters
    ----------
    FxC, FyC, FzC : array_like
        Forces at the wheel centre along the C axes [N].
    MxC, MyC, MzC : array_like
        Moments about the wheel centre along the C axes [N m].
    gamma : array_like
        Inclination angle [rad], a rotation about x (positive tilts the top to -y).
    loaded_radius : array_like
        Distance wheel centre - contact point, positive [m].

    Returns
    -------
    dict of numpy.ndarray
        ``Fx, Fy, Fz`` [N] and ``Mx, My, Mz`` [N m] in ISO-W at the contact point.
    """
    g = np.asarray(gamma, dtype=float)
    rl = np.asarray(loaded_radius, dtype=float)
    FxC, FyC, FzC = (np.asarray(v, dtype=float) for v in (FxC, FyC, FzC))
    MxC, MyC, MzC = (np.asarray(v, dtype=float) for v in (MxC, MyC, MzC))
    cg, sg = np.cos(g), np.sin(g)
    return {
        "Fx": FxC + 0.0 * g,
        "Fy": FyC * cg - FzC * sg,
        "Fz": FyC * sg + FzC * cg,
        "Mx": MxC - rl * FyC + 0.0 * g,
        "My": MyC * cg - MzC * sg + rl * FxC * cg,
        "Mz": MyC * sg + MzC * cg + rl * FxC * sg,
    }


def to_iso_w(frame: pd.DataFrame, axes: str, *, loaded_radius=None) -> pd.DataFrame:
    """A copy of a tidy force table (``Fx .. Mz``, ``alpha``, ``gamma``) in ISO-W.

    Parameters
    ----------
    frame : pandas.DataFrame
        Tidy table in ``axes``.
    axes : {"ISO-W", "SAE", "TYDEX-C"}
        The table's axis system.
    loaded_radius : float or array_like, optional
        Loaded radius [m], needed for TYDEX-C.

    Raises
    ------
    ValueError
        Unknown axis system, or TYDEX-C without a loaded radius.
    """
    if axes == "ISO-W":
        return frame.copy(deep=False)
    if axes == "SAE":
        return sae_to_iso_w(frame)
    if axes == "TYDEX-C":
        if loaded_radius is None:
            raise ValueError("TYDEX-C data need the loaded radius")
        out = frame.copy(deep=False)
        w = c_to_w(*(frame[c].to_numpy(float) for c in _FM), frame["gamma"].to_numpy(float),
                   loaded_radius)
        for col in _FM:
            out[col] = w[col]
        return out
    raise ValueError(f"unknown axis system '{axes}' (expected {', '.join(AXES)})")
