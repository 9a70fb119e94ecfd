"""Write complete MF 6.1 / 6.2 tyre property files (.tir) from the parameter table.

Layout (docs/tir-files.md): the 21 sections in the standard order, each after its
``$----name`` comment line, ``KEY = value $meaning [unit]`` in aligned columns, SI ``[UNITS]``,
a ``!``-comment header after the ``[MDI_HEADER]`` keys (tool, provenance, the NOMPRES warning),
unknown keys and tabular sections carried over from an input file, and last mfid's own
``[MFID_EXTENSIONS]`` (keys prefixed ``MFID_``). Numbers use the shortest round-trip form
(``repr``), integers are written as integers, so that read -> write -> read is exact; a fitted
file is written with ``digits`` significant digits instead (:data:`FIT_DIGITS` for
``mfid fit``): the digits the data determine, and far more than its standard errors allow,
rather than the 17 of a binary double.

Written for the simplest reader: CRLF line endings as in the reference files (some readers cut
each line at "newline minus 2"), and no ``=`` anywhere but between a key and its value (a
line-based reader that skips ``$``/``!`` lines and splits at ``=`` reads every data line and
nothing else), and plain ASCII as the header declares (``FILE_FORMAT : ASCII``): accented
letters in file names, tyre names or carried-over strings lose their accents, other non-ASCII
characters become ``?``. With ``sources``, each key's comment also says where its value came from
(fitted, with its standard error; taken from an input .tir; measured range; tyre.toml; or
default, not identified by the data); a fitted coefficient whose 95 % interval holds zero
(``|value| < ZERO_T x standard error``) is marked in its comment with :data:`ZERO_MARK`: the
data cannot tell it from 0. Written atomically.
"""
from __future__ import annotations

import math
import unicodedata
from collections.abc import Mapping, Sequence
from pathlib import Path

from identify.core.atomic import atomic_write_text
from identify.core.version import __version__
from identify.model.parameters import PARAMETERS, SECTIONS, defaults, spec

__all__ = ["write_tir", "format_tir", "format_value", "source_text", "comment_text",
           "DEFAULT_SOURCE", "FIT_DIGITS", "ZERO_MARK", "ZERO_T", "holds_zero"]

_SI_UNITS = {"LENGTH": ("meter", {"meter", "meters", "metre", "metres", "m"}),
             "FORCE": ("newton", {"newton", "newtons", "n"}),
             "ANGLE": ("radians", {"radian", "radians", "rad"}),
             "MASS": ("kg", {"kg", "kilogram", "kilograms"}),
             "TIME": ("second", {"second", "seconds", "sec", "s"})}
_KEY_WIDTH = 26
_VALUE_WIDTH = 24
_RULE_WIDTH = 70

_EXTENSION_NOTE = (
    "$ mfid extensions: coefficients the Magic Formula has no key for (mfid, "
    "identify.model.parameters).",
    "$ Other tools (MFeval, MF-Tyre/MF-Swift, ADAMS) ignore this section; all defaults are",
    "$ neutral. Sidewall stiffness scaling with pressure: c_b(p) is c_b0 (1 + MFID_F_* dpi);",
    "$ yaw stiffness form MFID_CMZ_FORM: 1 for T1 (PCMZ1), 2 for T2 (PCMZ1, MFID_PCMZ2, "
    "MFID_PCMZ3).",
)
DEFAULT_SOURCE = "default, not identified by these data"
"""The source comment of a key that kept its default value."""
FIT_DIGITS = 8
"""Significant digits of the numbers of a fitted .tir: a relative rounding of at most 5e-9, far
below any standard error of a fit, so the written file reproduces the fit to that precision."""
ZERO_T = 1.96
"""A fitted coefficient within this many standard errors of 0 has a 95 % interval (normal
quantile) that holds 0."""
ZERO_MARK = "95 % INTERVAL HOLDS 0"
"""The mark in the comment of a fitted coefficient the data cannot tell from 0."""
LINE_END = "\r\n"
"""Line ending of written files (as the reference .tir files)."""


def format_value(value: float | str, digits: int | None = None) -> str:
    """Format one value: integers as integers, other floats as ``repr`` (or with ``digits``
    significant digits), strings quoted.

    Raises
    ------
    ValueError
        For NaN/inf, or a string that cannot be quoted (both quote kinds, a line break).
    """
    if isinstance(value, str):
        if "\n" in value or "\r" in value:
            raise ValueError(f"string value with a line break: {value!r}")
        if "'" not in value:
            return f"'{value}'"
        if '"' not in value:
            return f'"{value}"'
        raise ValueError(f"string value with both quote characters: {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"cannot write a non-finite number: {value!r}")
    if digits is not None:
        number = float(f"{number:.{digits}g}")
    if number.is_integer() and abs(number) < 1e15:
        return str(int(number))
    return repr(number)


def holds_zero(value: float | str, stderr: float) -> bool:
    """Whether a fitted ``value`` lies within :data:`ZERO_T` standard errors of 0."""
    return (not isinstance(value, str) and math.isfinite(stderr) and stderr > 0
            and abs(float(value)) < ZERO_T * stderr)


def ascii_text(text: str) -> str:
    """``text`` in plain ASCII: accents dropped (NFKD), other non-ASCII characters ``?``."""
    decomposed = unicodedata.normalize("NFKD", str(text))
    kept = "".join(c for c in decomposed if not unicodedata.combining(c))
    return kept.encode("ascii", "replace").decode("ascii")


def comment_text(text: str) -> str:
    """``text`` made safe for a comment: one line, no ``=`` (a line-based reader splits at it)."""
    return " ".join(str(text).split()).replace("=", ":")


def source_text(kind: str, detail: str = "", stderr: float | None = None) -> str:
    """The source comment of a key: ``fitted MF/Fy0 +/- 0.012``, ``from input base.tir``,
    ``measured range``, ``tyre.toml`` or :data:`DEFAULT_SOURCE`."""
    text = " ".join(x for x in (kind, detail) if x)
    if stderr is not None and math.isfinite(stderr):
        text += f" +/- {stderr:.3g}"
    return comment_text(text)


def _line(key: str, value: float | str, comment: str, digits: int | None = None) -> str:
    text = format_value(value, digits)
    return f"{key:<{_KEY_WIDTH}}= {text:<{_VALUE_WIDTH}}$ {comment_text(comment)}".rstrip()


def _rule(section: str) -> str:
    name = section.lower()
    return "$" + "-" * max(4, _RULE_WIDTH - 1 - len(name)) + name


def _header_comments(comment_lines: Sequence[str]) -> list[str]:
    out = ["! : FILE_FORMAT : ASCII",
           f"! : TOOL : mfid {__version__} (Magic Formula identification workbench)"]
    for entry in comment_lines:
        for part in str(entry).splitlines() or [""]:
            out.append(f"! : COMMENT : {comment_text(part)}".rstrip())
    out.append("! : COMMENT : NOMPRES is the reference pressure of every pressure term: "
               "NEVER MODIFY NOMPRES (change INFLPRES instead)")
    return out


def _unit_value(name: str, value: float | str) -> str:
    canonical, spellings = _SI_UNITS[name]
    return value if isinstance(value, str) and value.strip().lower() in spellings else canonical


def format_tir(values: Mapping[str, float | str], *, fittyp: int,
               comment_lines: Sequence[str] = (),
               unknown: Mapping[str, float | str] | None = None,
               tables: Mapping[str, Sequence[str]] | None = None,
               sources: Mapping[str, object] | None = None,
               digits: int | None = None) -> str:
    """Return the text of a .tir file; see :func:`write_tir` for the parameters."""
    if fittyp not in (61, 62):
        raise ValueError(f"fittyp must be 61 (MF 6.1) or 62 (MF 6.2), not {fittyp!r}")
    full = defaults()
    for name, value in values.items():
        spec(name)  # KeyError for a name that is not in the table
        full[name] = value
    full["FITTYP"] = fittyp
    extra: dict[str, list[tuple[str, float | str]]] = {}
    for dotted, value in (unknown or {}).items():
        section, _, key = dotted.rpartition(".")
        if not section or not key:
            raise ValueError(f"unknown keys are named 'SECTION.KEY', not {dotted!r}")
        extra.setdefault(section.upper(), []).append((key, value))

    lines: list[str] = []
    counts: dict[str, int] = {}

    def source(name: str, value) -> str:
        if sources is None:
            return ""
        given = sources.get(name)
        if hasattr(given, "kind"):  # a typed source (identify.fit.sources.KeySource)
            kind, text = str(given.kind), str(given.text())
            stderr = float(getattr(given, "stderr", math.nan))
            if kind == "fitted" and holds_zero(value, stderr):
                counts[ZERO_MARK] = counts.get(ZERO_MARK, 0) + 1
                text += (f"; {ZERO_MARK} (|value| is {abs(float(value)) / stderr:.2g} "
                         "standard errors)")
        else:
            text = given or (DEFAULT_SOURCE if value == spec(name).default else "")
            kind = text.split(",", 1)[0].split(" ", 1)[0] if text else "unstated"
        counts[kind] = counts.get(kind, 0) + 1
        return f"; {text}" if text else ""

    def emit_section(section: str) -> None:
        lines.extend([_rule(section), f"[{section}]"])
        if section == "MFID_EXTENSIONS":
            lines.extend(_EXTENSION_NOTE)
        for p in (q for q in PARAMETERS if q.section == section):
            value = full[p.name]
            if p.name in _SI_UNITS:
                value = _unit_value(p.name, value)
            elif fittyp not in p.write_for and value == p.default:
                continue
            lines.append(_line(p.tir_key, value, p.meaning + source(p.name, value),
                               None if p.is_string else digits))
        for key, value in extra.pop(section, []):
            lines.append(_line(key, value, "(not an MFeval key: kept from the input file)"))
        if section == "MDI_HEADER":
            lines.extend(_header_comments(comment_lines))
            header_end = len(lines)
            lines.append("")  # the key-source summary, filled in once every key is written
            marks.append(header_end)

    marks: list[int] = []
    for section in SECTIONS[:-1]:
        emit_section(section)
    for section in [s for s in extra if s not in SECTIONS]:
        emit_section(section)
    for section, rows in (tables or {}).items():
        lines.extend([_rule(section), f"[{section.upper()}]"])
        lines.extend(str(r).rstrip("\r\n") for r in rows)
    emit_section(SECTIONS[-1])
    for at in marks:
        if sources is None:
            del lines[at]
        else:
            zero = counts.pop(ZERO_MARK, 0)
            lines[at] = comment_text("! : COMMENT : key sources (in each comment): " + ", ".join(
                f"{n} {k}" for k, n in sorted(counts.items(), key=lambda kv: -kv[1]))
                + (f"; {zero} fitted marked {ZERO_MARK}" if zero else ""))
    return ascii_text(LINE_END.join(lines) + LINE_END)


def write_tir(path: str | Path, values: Mapping[str, float | str], *, fittyp: int,
              comment_lines: Sequence[str] = (),
              unknown: Mapping[str, float | str] | None = None,
              tables: Mapping[str, Sequence[str]] | None = None,
              sources: Mapping[str, object] | None = None,
              digits: int | None = None) -> Path:
    """Write a complete MF 6.1 or 6.2 .tir file atomically.

    Parameters
    ----------
    path : str or Path
        Target file (its directory must exist).
    values : mapping
        Parameter-table names -> values in SI (floats) or strings without quotes; keys not
        given take the MFeval default. ``FITTYP`` is taken from ``fittyp``.
    fittyp : int
        61 (MF 6.1) or 62 (MF 6.2). The MF 6.2-only keys (Q_FCY2, Q_CAM1..3, Q_FYS1..3,
        ENV_C1/2) are written for 62, and for 61 only when they differ from the default; the
        MF 5.2-only keys, FUNCTION_NAME and SWITCH_INTEG only when they differ from the default.
    comment_lines : sequence of str
        Provenance lines for the ``!`` header (inputs, checksums, fit settings ...).
    unknown : mapping, optional
        Keys outside the table, ``"SECTION.KEY"`` -> value, written back in their sections
        (see :attr:`identify.io.tir.TirFile.unknown`).
    tables : mapping, optional
        Raw lines of tabular sections (``[SHAPE]`` ...), written before ``[MFID_EXTENSIONS]``.
    sources : mapping, optional
        Table name -> where the value came from: a text (:func:`source_text`) or a typed
        source with ``kind`` and ``text()`` (:class:`identify.fit.sources.KeySource`),
        appended to the key's comment; a key without an entry is marked
        :data:`DEFAULT_SOURCE` when it holds its default. The header counts the sources by
        kind. A fitted key whose standard error puts 0 in its 95 % interval is marked
        :data:`ZERO_MARK`. None: no source comments.
    digits : int, optional
        Significant digits of every number (:data:`FIT_DIGITS` for a fitted file); None: the
        shortest form that reads back exactly.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    KeyError
        For a name in ``values`` that is not in the parameter table.
    ValueError
        For an unsupported ``fittyp`` or a value that cannot be written (NaN, inf ...).
    """
    text = format_tir(values, fittyp=fittyp, comment_lines=comment_lines, unknown=unknown,
                      tables=tables, sources=sources, digits=digits)
    return atomic_write_text(path, text, encoding="ascii")
