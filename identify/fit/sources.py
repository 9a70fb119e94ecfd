"""Where each value of a written .tir came from: one :class:`KeySource` per key.

A vehicle-dynamics engineer reading a .tir needs to know, key by key, which values the data
determined and which are placeholders. Every key of a fitted .tir gets a source of one kind:

- ``fitted``: identified by a fit (``detail`` names it, ``relation/form`` or ``MF/<stage>
  (trailer)``), with its standard error;
- ``held``: held at its default in a fit that would otherwise free it (by ``--hold`` or because
  the data could not identify it; ``detail`` says why);
- ``tyre.toml``: nominal load and pressure, unloaded radius, dimensions from the size string;
- ``measured range``: a validity limit spanned by the fitted data points;
- ``input``: taken from an input .tir (``mfid discover --base``);
- ``setting``: an mfid setting (FITTYP from ``--fittyp``);
- ``file format``: keys that describe the file (FILE_TYPE, units ...), not the tyre;
- ``default``: not identified by these data (the MFeval default value).

fit.json lists the same records (``tir.key_sources``) and each .tir comment ends with
:meth:`KeySource.text`.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from identify.core.serial import Serial, from_data

__all__ = ["KINDS", "KeySource", "DEFAULT", "FITTED", "FORMAT", "HELD", "INPUT", "MEASURED",
           "SETTING", "TYRE_TOML"]

FITTED = "fitted"
HELD = "held"
TYRE_TOML = "tyre.toml"
MEASURED = "measured range"
INPUT = "input"
SETTING = "setting"
FORMAT = "file format"
DEFAULT = "default"
KINDS = (FITTED, HELD, TYRE_TOML, MEASURED, INPUT, SETTING, FORMAT, DEFAULT)
"""Every kind of source, in the order summaries list them."""

_DEFAULT_TEXT = "default, not identified by these data"


@dataclass(frozen=True)
class KeySource(Serial):
    """The source of one .tir key.

    Attributes
    ----------
    kind : str          one of :data:`KINDS`
    detail : str        the fit (``CFx/quadratic_load``, ``MF/Fy0 (trailer)``), the tyre.toml
                        field, the data the range was taken from, or why a key was held
    stderr : float      standard error of a fitted value [the key's SI unit]; NaN otherwise
    """

    kind: str
    detail: str = ""
    stderr: float = math.nan

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown key-source kind {self.kind!r}; one of {', '.join(KINDS)}")

    @classmethod
    def fitted(cls, detail: str, stderr: float = math.nan) -> KeySource:
        return cls(FITTED, detail, float(stderr))

    @classmethod
    def default(cls) -> KeySource:
        return cls(DEFAULT)

    def text(self) -> str:
        """One line for the .tir comment: ``fitted CFx/quadratic_load +/- 0.012``,
        ``tyre.toml size 225/50 R17``, ``measured range of 15 CFx points``,
        ``default, not identified by these data`` ..."""
        if self.kind == DEFAULT:
            return _DEFAULT_TEXT + (f" ({self.detail})" if self.detail else "")
        text = " ".join(x for x in (self.kind, self.detail) if x)
        if math.isfinite(self.stderr):
            text += f" +/- {self.stderr:.3g}"
        return text

    @property
    def supplied_by(self) -> str:
        """The ``relation/form`` (or ``MF/<stage>``) of a fitted key, else ""."""
        if self.kind != FITTED:
            return ""
        return self.detail.split(" ", 1)[0]

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | str) -> KeySource:
        """Inverse of :meth:`to_dict` (field by field, a NaN stderr as null); a plain string
        (fit.json before typed sources: the ``relation/form`` that supplied the key) reads as
        a fitted source."""
        return cls.fitted(d) if isinstance(d, str) else from_data(cls, d)
