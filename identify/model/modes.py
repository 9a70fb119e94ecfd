"""useMode: the three-digit switch of MFeval (limit checks, alpha-star, turn slip)."""
from __future__ import annotations

from dataclasses import dataclass

FIT_MODE = 211
"""useMode of the fits, of the Flatplank quantities and of every comparison with a fit: no limit
checks, no low-speed blending, alpha* = alpha (docs/model.md, section 2). The plank rolls far
below VXLOW: the low-speed reductions of the model are a numerical device there, not physics."""
TRAILER_MODE = 111
"""useMode of the trailer sweeps: limit checks on, as MFeval's default."""


@dataclass(frozen=True)
class UseMode:
    """Decoded MFeval useMode.

    Attributes
    ----------
    code : int
        The three-digit code (111, 121, 211, 221).
    limits : bool
        Hundreds digit 1: clip inputs to the .tir ranges, low-speed model, E <= 1 clips.
    alpha_star : bool
        Tens digit 2: alpha* = tan(alpha)*sgn(Vx), gamma* = sin(gamma) (book option).
    turn_slip : bool
        Units digit 2: turn slip. Not supported (steady-state fitting does not need it).
    """

    code: int
    limits: bool
    alpha_star: bool
    turn_slip: bool

    @classmethod
    def from_code(cls, code: int) -> UseMode:
        """Decode ``code``; raise ValueError for anything but 1x1/2x1 with x in {1, 2}."""
        code = int(code)
        hundreds, tens, units = code // 100, (code // 10) % 10, code % 10
        if code < 100 or code > 999 or hundreds not in (1, 2) or tens not in (1, 2) \
                or units not in (1, 2):
            raise ValueError(f"useMode {code} is not valid: use 111, 121, 211 or 221")
        if units == 2:
            raise ValueError(f"useMode {code}: turn slip (units digit 2) is not supported; "
                             "use 111, 121, 211 or 221")
        return cls(code=code, limits=hundreds == 1, alpha_star=tens == 2, turn_slip=False)
