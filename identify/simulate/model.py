"""The simulated tyre: the .tir the data are made from, the relations, the rig; and a run.

:class:`TyreModel` answers the questions every run generator and the truth table ask (deflection,
loaded radius, Re, sigma_y, Magic Formula outputs at Flatplank conditions), vectorised over
loads and pressures, so that the truth and the runs cannot disagree.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.relations import dpi as _dpi
from identify.simulate.coefficients import Relations
from identify.simulate.rig import Rig

__all__ = ["TyreModel", "Run"]


@dataclass(frozen=True)
class Run:
    """One simulated run before noise.

    Attributes
    ----------
    run_id : str
        Unique id (= file stem).
    file : str
        Path relative to the folder.
    kind, test : str
        Manifest ``kind`` and ``test``.
    conditions : dict
        Manifest ``conditions``.
    channels : dict of ndarray
        Clean channels in file order.
    noisy : tuple of str
        Channels that receive measurement noise.
    contact : dict of ndarray or None
        Flatplank runs: contact-patch Fx, Fy, Fz, Mx, My, Mz (ISO-W) and gamma, as measured
        (artefacts included, noise excluded); what the hub transform of the clean channels gives.
    """

    run_id: str
    file: str
    kind: str
    test: str
    conditions: dict
    channels: dict
    noisy: tuple[str, ...]
    contact: dict | None = field(default=None)


@dataclass(frozen=True)
class TyreModel:
    """The tyre the data are made from.

    Attributes
    ----------
    params : mapping
        Numeric .tir values in SI used for the data (hidden effects included).
    relations : Relations
        Flatplank structural relations.
    rig : Rig
        Rig constants and effect shapes.
    """

    params: Mapping[str, float]
    relations: Relations
    rig: Rig

    @property
    def r0(self) -> float:
        """Unloaded radius [m]."""
        return float(self.params["UNLOADED_RADIUS"])

    @property
    def fz0(self) -> float:
        """Nominal load FNOMIN [N]."""
        return float(self.params["FNOMIN"])

    @property
    def p0(self) -> float:
        """Nominal pressure NOMPRES [Pa]."""
        return float(self.params["NOMPRES"])

    def dp(self, p_bar):
        """Pressure increment of the relations at ``p_bar`` [bar] [-]."""
        return _dpi(np.asarray(p_bar, dtype=float) * 1e5, self.relations.p0)

    def rho(self, fz, p_bar):
        """Static deflection [m] at load ``fz`` [N] (qFz relation)."""
        return self.relations.vertical.rho(fz, self.dp(p_bar))

    def loaded_radius(self, fz, p_bar):
        """Loaded radius [m]: the free radius R0 Q_RE0 minus the deflection."""
        return self.r0 * float(self.params["Q_RE0"]) - self.rho(fz, p_bar)

    def mf(self, fz, p_bar, alpha=0.0, gamma=0.0, kappa=0.0, vx=None, mode=FIT_MODE):
        """Magic Formula outputs (dict of arrays) broadcast over the arguments.

        ``fz`` [N], ``p_bar`` [bar], ``alpha``, ``gamma`` [rad], ``kappa`` [-], ``vx`` [m/s]
        (default: the Flatplank rolling speed).
        """
        vx = self.rig.rolling_speed if vx is None else vx
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                       for v in (fz, p_bar, alpha, gamma, kappa, vx)))
        shape = arrays[0].shape
        fz_, p_, a_, g_, k_, v_ = (np.ravel(v) for v in arrays)
        out = evaluate(self.params, fz_, k_, a_, g_, v_, p=p_ * 1e5, mode=mode)
        return {k: np.reshape(v, shape) for k, v in out.items()
                if np.ndim(v) and v.size == fz_.size}

    def re(self, fz, p_bar):
        """Effective rolling radius at Flatplank speed [m]."""
        return self.mf(fz, p_bar)["Re"]

    def sigma_y(self, fz, p_bar):
        """Lateral relaxation length |Kya| / CFy [m] (Kya of the .tir, CFy of the relations)."""
        kya = self.mf(fz, p_bar)["Kya"]
        return np.abs(kya) / self.relations.cfy(fz, self.dp(p_bar))
