"""Read Magic Formula tyre property files (.tir) into SI values keyed by the parameter table.

The syntax is described in docs/tir-files.md: ``[SECTION]`` headers, ``KEY = VALUE $comment``
lines, ``$`` and ``!`` comment lines, single- or double-quoted strings. Real files also bring LF
or CRLF (or CR) line ends, tabs, a UTF-8 BOM, exponents such as ``5.6519e+005`` or ``1.E-3``,
empty values (``ROAD_INCREMENT =``, which then take the default), keys in any case, non-SI
``[UNITS]`` and tabular sections (``[SHAPE]``, ``[DEFLECTION_LOAD_CURVE]``), which are kept raw.

Every problem is an :class:`identify.core.errors.InputError` naming file, line and key; the message
texts are part of the interface (the tests assert them).
"""
from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from identify.core.errors import InputError
from identify.core.plausible import judge
from identify.core.serial import Serial
from identify.core.units import dimension_factor, unit_factor
from identify.io.common import file_problem
from identify.model.parameters import EXTENSION_PREFIX, PARAMETERS, spec

__all__ = ["TirFile", "read_tir", "SUPPORTED_FITTYPS", "KNOWN_FITTYPS", "UNIT_KEYS"]

#: FITTYP values of Magic Formula files in general (5.1, 5.2, 6.0, 6.1, 6.2).
KNOWN_FITTYPS = (5, 6, 21, 60, 61, 62)
#: FITTYP values mfid evaluates (MF 6.1 and MF 6.2).
SUPPORTED_FITTYPS = (61, 62)

#: The [UNITS] keys of a .tir and the dimension of each (identify.core.units).
UNIT_KEYS: dict[str, str] = {"LENGTH": "length", "FORCE": "force", "ANGLE": "angle",
                             "MASS": "mass", "TIME": "time", "PRESSURE": "pressure"}
_UNIT_SYMBOL = {"LENGTH": "L", "FORCE": "F", "ANGLE": "A", "MASS": "M", "TIME": "T",
                "PRESSURE": "P"}
_SI_NAME = {"LENGTH": "meter", "FORCE": "newton", "ANGLE": "radians", "MASS": "kg",
            "TIME": "second"}
_TABLE_SECTIONS = frozenset({"SHAPE", "DEFLECTION_LOAD_CURVE"})
_KV_SECTIONS = frozenset(p.section for p in PARAMETERS)
_TABLE_NAMES = frozenset(p.name for p in PARAMETERS)
_EXTENSION_NAMES = frozenset(p.name for p in PARAMETERS if p.section == "MFID_EXTENSIONS")

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][+-]?\d+)?")
_NONFINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)
_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_HEADER = re.compile(r"\[\s*([A-Za-z0-9_]+)\s*\]\s*(?:[$!].*)?")
_NON_UTF8 = re.compile("[\udc80-\udcff]")


@dataclass(frozen=True)
class TirFile(Serial):
    """A parsed .tir file, all dimensional values in SI.

    Attributes
    ----------
    path : str
        The file as given to :func:`read_tir`.
    fittyp : int
        61 (MF 6.1) or 62 (MF 6.2).
    values : mapping
        Every key of the parameter table: the file's value (converted to SI) or the default.
        Numbers are floats, strings have no quotes. The ``[UNITS]`` keys name the units of these
        values (the SI names if the file's units were converted).
    units : mapping
        The ``[UNITS]`` strings as written in the file (including PRESSURE if given).
    defaults_used : tuple of str
        Keys that took their default, in table order.
    unknown : mapping
        Keys that are not in the table, as ``"SECTION.KEY"`` -> value (not unit-converted).
    tables : mapping
        Raw data lines of tabular sections (``[SHAPE]`` ...), per section.
    sha256 : str
        SHA-256 of the file bytes.
    warnings : tuple of str
        Harmless oddities (a key given twice with the same value ...).
    """

    path: str
    fittyp: int
    values: Mapping[str, float | str]
    units: Mapping[str, str]
    defaults_used: tuple[str, ...]
    unknown: Mapping[str, float | str]
    tables: Mapping[str, tuple[str, ...]]
    sha256: str
    warnings: tuple[str, ...] = field(default=())

    serial_order = ("path", "fittyp", "sha256")  # ``to_dict``: then the other fields

    def __post_init__(self) -> None:
        for name in ("values", "units", "unknown", "tables"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))

    def __reduce__(self):  # MappingProxyType does not pickle; rebuild from plain dicts
        return (TirFile, (self.path, self.fittyp, dict(self.values), dict(self.units),
                          self.defaults_used, dict(self.unknown), dict(self.tables),
                          self.sha256, self.warnings))

    def params(self) -> dict[str, float]:
        """All numeric values (SI), FITTYP included as a float, for the forward model."""
        return {k: v for k, v in self.values.items() if not isinstance(v, str)}


@dataclass
class _Entry:
    line: int
    raw: str
    value: float | str


def _read_text(path: str) -> tuple[str, str]:
    why = file_problem(path, ".tir file")
    if why and not why.startswith(("no such", "is a directory")):  # a FIFO would block
        raise InputError(path, f"cannot read file: {why}")
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError(path, "cannot read file: no such file") from None
    except IsADirectoryError:
        raise InputError(path, "cannot read file: is a directory") from None
    except PermissionError:
        raise InputError(path, "cannot read file: permission denied") from None
    except OSError as exc:
        raise InputError(path, f"cannot read file: {exc.strerror or exc}") from None
    digest = hashlib.sha256(data).hexdigest()
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        text = data.decode("utf-16", "surrogateescape")
    elif b"\x00" in data:
        raise InputError(path, "cannot read file: binary data (NUL bytes), not a .tir text file")
    else:
        text = data.decode("utf-8", "surrogateescape")
    return text.lstrip("\ufeff"), digest


def _split_comment(text: str) -> str:
    """The part of a data line before a ``$`` or ``!`` comment that is outside quotes."""
    quote = None
    for i, ch in enumerate(text):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch in "$!":
            return text[:i]
    return text


def _number(path: str, line: int, key: str, raw: str) -> float:
    if raw[:1] in "'\"":
        raise InputError(path, f"expected a number, got the string {raw}", line=line, key=key)
    if _NONFINITE.fullmatch(raw):
        raise InputError(path, f"not a finite number '{raw}'", line=line, key=key)
    if not _NUMBER.fullmatch(raw):
        raise InputError(path, f"malformed number '{raw}'", line=line, key=key)
    value = float(raw.replace("d", "e").replace("D", "e"))
    if not math.isfinite(value):
        raise InputError(path, f"not a finite number '{raw}'", line=line, key=key)
    return value


def _unquote(path: str, line: int, key: str, raw: str) -> tuple[str, bool]:
    if raw[:1] in "'\"":
        if len(raw) < 2 or raw[-1] != raw[0]:
            raise InputError(path, f"unterminated string {raw}", line=line, key=key)
        return raw[1:-1], True
    return raw, False


def _fmt_fittyp(value: float) -> str:
    return str(int(value)) if value.is_integer() else repr(value)


def _unit_scale(key: str, unit: str) -> float | None:
    """SI value of one ``unit`` given for the [UNITS] ``key``, None when unknown."""
    try:
        return unit_factor(unit, UNIT_KEYS[key])
    except KeyError:
        return None


def _classify(section: str, key: str) -> tuple[str, str]:
    """Return (kind, name): kind is 'unit', 'known' or 'unknown'."""
    if section == "UNITS" and key in UNIT_KEYS:
        return "unit", key
    if key == "MASS":
        return "known", "MASS1"
    if key.startswith(EXTENSION_PREFIX) and key[len(EXTENSION_PREFIX):] in _EXTENSION_NAMES:
        return "known", key[len(EXTENSION_PREFIX):]
    if key in _TABLE_NAMES and key not in _SI_NAME:
        return "known", key
    return "unknown", f"{section}.{key}"


def read_tir(path: str | Path) -> TirFile:
    """Read a .tir file; convert to SI; fill missing keys with MFeval's defaults.

    Parameters
    ----------
    path : str or Path
        The tyre property file (MF 6.1, FITTYP 61, or MF 6.2, FITTYP 62).

    Returns
    -------
    TirFile

    Raises
    ------
    InputError
        For an unreadable, empty or malformed file, an unsupported or missing FITTYP, a key
        of a section that has no header (read in the section above: a lost header line), a key
        given twice with different values, a non-number where a number is required, a
        non-finite number or an unknown unit.
    """
    path = str(path)
    text, digest = _read_text(path)
    if not text.strip():
        raise InputError(path, "empty file")
    text = text.replace("\r\n", "\n").replace("\r", "\n")

    entries: dict[str, _Entry] = {}
    tables: dict[str, list[str]] = {}
    warnings: list[str] = []
    section: str | None = None
    kind: str | None = None  # 'kv', 'table' or 'auto' for the current section
    headers: set[str] = set()
    misplaced: list[tuple[int, str, str]] = []  # (line, key, section read in) of a table key
    for lineno, line in enumerate(text.split("\n"), start=1):
        s = line.strip()
        if not s or s[0] in "$!":
            continue
        body = _split_comment(s).strip()
        bad = _NON_UTF8.search(body)
        if bad:
            key = body.partition("=")[0].strip()
            raise InputError(path, f"non-UTF-8 byte 0x{ord(bad.group()) - 0xDC00:02X}",
                             line=lineno, key=key.upper() if _KEY.fullmatch(key) else None)
        if s.startswith("["):
            m = _HEADER.fullmatch(s)
            if m is None:
                raise InputError(path, f"cannot parse line: '{s}'", line=lineno)
            section = m.group(1).upper()
            headers.add(section)
            kind = ("kv" if section in _KV_SECTIONS else
                    "table" if section in _TABLE_SECTIONS else "auto")
            if kind == "table":
                tables.setdefault(section, [])
            continue
        if section is None:
            key = body.split("=", 1)[0].strip() if "=" in body else None
            if key and _KEY.fullmatch(key):
                raise InputError(path, "KEY = VALUE before the first [SECTION] header",
                                 line=lineno, key=key.upper())
            raise InputError(path, f"cannot parse line: '{s}'", line=lineno)
        if kind == "auto":
            kind = "kv" if "=" in body else "table"
        if kind == "table":
            tables.setdefault(section, []).append(line.rstrip())
            continue
        key, eq, raw = body.partition("=")
        key, raw = key.strip(), raw.strip()
        if not eq or not _KEY.fullmatch(key):
            raise InputError(path, f"cannot parse line: '{s}'", line=lineno)
        what, name = _classify(section, key.upper())
        if what == "known" and spec(name).section != section:
            misplaced.append((lineno, name, section))
        if not raw:
            if what == "unknown":
                entries.setdefault(name, _Entry(lineno, raw, ""))
            continue  # an empty known value is missing: the default applies
        if what == "unit":
            unit, _ = _unquote(path, lineno, name, raw)
            if unit.strip() != "default" and _unit_scale(name, unit) is None:
                raise InputError(path, f"unknown unit '{unit}'", line=lineno, key=name)
            value: float | str = unit
        elif what == "known" and spec(name).is_string:
            value = _unquote(path, lineno, name, raw)[0]
        elif what == "known":
            value = _number(path, lineno, name, raw)
            if name == "FITTYP" and value not in SUPPORTED_FITTYPS:
                raise InputError(path, f"unsupported FITTYP {_fmt_fittyp(value)} (mfid "
                                 "evaluates MF 6.1 = 61 and MF 6.2 = 62)",
                                 line=lineno, key=name)
        else:
            value, quoted = _unquote(path, lineno, name, raw)
            if not quoted and _NUMBER.fullmatch(value):
                number = float(value.replace("d", "e").replace("D", "e"))
                value = number if math.isfinite(number) else value
        old = entries.get(name)
        if old is not None:
            if old.value != value:
                raise InputError(path, f"given twice with different values (line {old.line}: "
                                 f"{old.raw}, line {lineno}: {raw})", line=lineno, key=name)
            warnings.append(f"{name} given twice with the same value "
                            f"(lines {old.line} and {lineno})")
            continue
        entries[name] = _Entry(lineno, raw, value)

    for lineno, name, found_in in misplaced:  # a header line lost: keys join the section above
        own = spec(name).section
        if own not in headers:
            raise InputError(path, f"no [{own}] section header: the [{own}] key is read as part "
                             f"of [{found_in}]", line=lineno, key=name)
    if "FITTYP" not in entries:
        raise InputError(path, "no FITTYP found: a Magic Formula .tir file needs "
                         "FITTYP = 61 or 62 in [MODEL]")
    return _assemble(path, digest, entries, tables, warnings)


#: Keys the model divides by, with their quantity of identify.core.plausible: non-zero and
#: plausible in SI.
_DIVIDING = (("FNOMIN", "load"), ("UNLOADED_RADIUS", "radius"), ("NOMPRES", "pressure"),
             ("LONGVL", "speed"))


def _assemble(path: str, digest: str, entries: dict[str, _Entry],
              tables: dict[str, list[str]], warnings: list[str]) -> TirFile:
    units = {k: str(entries[k].value) for k in UNIT_KEYS if k in entries}
    scales = {_UNIT_SYMBOL[k]: _unit_scale(k, u) or 1.0 for k, u in units.items()}
    if "PRESSURE" not in units:
        scales["P"] = scales.get("F", 1.0) / scales.get("L", 1.0) ** 2
    values: dict[str, float | str] = {}
    defaults_used = []
    for p in PARAMETERS:
        if p.name in _SI_NAME:  # a unit name: says what the values are in, i.e. SI
            unit = units.get(p.name)
            keep = unit is not None and unit.strip() != "default" and \
                scales[_UNIT_SYMBOL[p.name]] == 1.0
            values[p.name] = unit if keep else _SI_NAME[p.name]
            if unit is None:
                defaults_used.append(p.name)
        elif p.name in entries:
            value = entries[p.name].value
            if not p.is_string and p.dimension != "1":
                factor = dimension_factor(p.dimension, scales)
                if factor != 1.0:
                    value = value * factor
            values[p.name] = value
        else:
            values[p.name] = p.default
            defaults_used.append(p.name)
    for key, quantity in _DIVIDING:  # in SI, after the [UNITS] scaling
        if key in entries and isinstance(values[key], float):
            found = judge(quantity, values[key], what="value in SI")
            if values[key] == 0.0 or (found is not None and found.is_error):
                why = "must not be 0: the model divides by it" if values[key] == 0.0 \
                    else found.message
                raise InputError(path, why, line=entries[key].line, key=key)
            if found is not None:
                warnings.append(f"{key}: {found.message}")
    unknown = {k: e.value for k, e in entries.items() if "." in k}
    if unknown and any(v != 1.0 for v in scales.values()):
        warnings.append("unknown keys are kept as read, not converted to SI: "
                        + ", ".join(unknown))
    return TirFile(path=path, fittyp=int(values["FITTYP"]), values=values, units=units,
                   defaults_used=tuple(defaults_used), unknown=unknown,
                   tables={k: tuple(v) for k, v in tables.items()}, sha256=digest,
                   warnings=tuple(warnings))
