"""The Tire Test Consortium's channels: names, units (SI and USCS files), TYDEX counterparts.

Shared by the TTC readers (:mod:`identify.io.ttc.files` for ``.mat``, :mod:`identify.io.ttc.dat` for
``.dat``) and the trailer loader. Real files spell a name in another case or pad it to the
width of a MATLAB char matrix: :func:`ttc_name` gives the table's spelling.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["TTC_CHANNELS", "TTC_TO_TYDEX", "TtcChannel", "is_ttc_naming", "ttc_name"]


@dataclass(frozen=True)
class TtcChannel:
    """One TTC channel: its dimension, units (SI and USCS files), meaning, TYDEX counterpart."""

    dimension: str
    si_unit: str
    uscs_unit: str
    long_name: str
    tydex: str | None


#: The TTC channels in file order (the public description's names and units).
TTC_CHANNELS: dict[str, TtcChannel] = {
    "ET": TtcChannel("time", "s", "s", "elapsed time", "RUNTIME"),
    "V": TtcChannel("speed", "kph", "mph", "road speed", "LONGVEL"),
    "N": TtcChannel("angular_velocity", "rpm", "rpm", "wheel rotational speed", "WHROTSPD"),
    "SA": TtcChannel("angle", "deg", "deg", "slip angle", "SLIPANGL"),
    "IA": TtcChannel("angle", "deg", "deg", "inclination angle", "INCLANGL"),
    "RL": TtcChannel("length", "cm", "in", "loaded radius", "RLOADED"),
    "RE": TtcChannel("length", "cm", "in", "effective rolling radius", "REFFECT"),
    "P": TtcChannel("pressure", "kPa", "psi", "inflation pressure", "INFLPRES"),
    "FX": TtcChannel("force", "N", "lbf", "longitudinal force", "FX"),
    "FY": TtcChannel("force", "N", "lbf", "lateral force", "FYW"),
    "FZ": TtcChannel("force", "N", "lbf", "normal force", "FZW"),
    "MX": TtcChannel("moment", "N-m", "ft-lb", "overturning moment", "MXW"),
    "MZ": TtcChannel("moment", "N-m", "ft-lb", "aligning moment", "MZW"),
    "NFX": TtcChannel("ratio", "none", "none", "normalized longitudinal force", None),
    "NFY": TtcChannel("ratio", "none", "none", "normalized lateral force", None),
    "RST": TtcChannel("temperature", "deg C", "deg F", "road surface temperature", "TROAD"),
    "TSTI": TtcChannel("temperature", "deg C", "deg F", "tread temperature inner", "TTREADI"),
    "TSTC": TtcChannel("temperature", "deg C", "deg F", "tread temperature centre", "TTREADC"),
    "TSTO": TtcChannel("temperature", "deg C", "deg F", "tread temperature outer", "TTREADO"),
    "AMBTMP": TtcChannel("temperature", "deg C", "deg F", "ambient temperature", "TAMBIENT"),
    "SR": TtcChannel("ratio", "none", "none", "slip ratio based on RL", None),
    "SL": TtcChannel("ratio", "none", "none", "slip ratio based on RE", "LONGSLIP"),
    "RUN": TtcChannel("ratio", "none", "none", "run number", None),
}
#: TTC channel name -> TYDEX channel name of identify.io.trailer.files.
TTC_TO_TYDEX: dict[str, str] = {k: c.tydex for k, c in TTC_CHANNELS.items() if c.tydex}


def ttc_name(name: str) -> str:
    """A channel name as TTC writes it: ``"fz  "`` -> ``"FZ"`` (a name padded to the width of
    a MATLAB char matrix, or in another case); a name that is not a TTC channel only
    stripped."""
    name = str(name).strip()
    return name.upper() if name.upper() in TTC_CHANNELS else name


def is_ttc_naming(names) -> bool:
    """True when channel names are TTC's (``ET`` and two more TTC names, no ``RUNTIME``)."""
    names = set(names)
    return "ET" in names and "RUNTIME" not in names and len(names & TTC_CHANNELS.keys()) >= 3
