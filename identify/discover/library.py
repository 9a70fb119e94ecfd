"""The library of candidate effects, kept as data (``library.toml`` in this package).

A candidate is a named extension of a base model: it frees one or a few coefficients that the
base model holds at their neutral values (PPY5 = 0, QSY7 = 1, ...). Users extend or override
the shipped library with their own TOML file of the same format (``--candidates FILE``); an
entry with the name of a shipped one replaces it.
"""
from __future__ import annotations

import fnmatch
import math
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from importlib.resources import files
from pathlib import Path

from identify.core.errors import InputError
from identify.core.serial import Serial

__all__ = ["Candidate", "BaseForm", "Library", "load_library"]

_REQUIRED = ("name", "coefficients", "relations", "equation", "description")


@dataclass(frozen=True)
class Candidate(Serial):
    """One candidate effect.

    Attributes
    ----------
    name : str
        Unique name (the .tir key for one-coefficient entries).
    coefficients : Mapping[str, float]
        Coefficient -> neutral value [-]; several coefficients form a block (tested jointly).
    bounds : Mapping[str, tuple[float, float]]
        Coefficient -> (lower, upper) for the refit [-].
    relations : tuple of str
        Glob patterns of the problem names it applies to (``"MF/Fy"``, ``"CFy*"``).
    equation : str
        The equation it changes.
    description : str
        One line of physics (``"camber thrust stiffness depends on inflation pressure"``).
    expected_sign : str
        ``"+"``, ``"-"`` or ``""``: the physically expected sign of the first coefficient.
    source : str
        ``"library"`` or the user file it came from.
    nuisance : bool
        A property of the measurement, not of the tyre (a drift along the session): its
        coefficients are local to each problem and never written to the .tir.
    """

    name: str
    coefficients: Mapping[str, float]
    bounds: Mapping[str, tuple[float, float]]
    relations: tuple[str, ...]
    equation: str
    description: str
    expected_sign: str = ""
    source: str = "library"
    nuisance: bool = False

    @property
    def dof(self) -> int:
        """Number of coefficients it frees."""
        return len(self.coefficients)

    def applies_to(self, problem_name: str) -> bool:
        """True when ``problem_name`` matches one of :attr:`relations`."""
        return any(fnmatch.fnmatchcase(problem_name, pat) for pat in self.relations)


@dataclass(frozen=True)
class BaseForm:
    """A named base form (``--base-form``).

    Attributes
    ----------
    name : str
    problems : tuple of str    glob patterns of the problems it selects
    neutral : tuple of str     library coefficients held at their neutral values
    description : str
    """

    name: str
    problems: tuple[str, ...]
    neutral: tuple[str, ...]
    description: str = ""

    def selects(self, problem_name: str) -> bool:
        return any(fnmatch.fnmatchcase(problem_name, pat) for pat in self.problems)


@dataclass(frozen=True)
class Library:
    """The candidates and base forms.

    Attributes
    ----------
    candidates : tuple of Candidate
    forms : Mapping[str, BaseForm]
    """

    candidates: tuple[Candidate, ...]
    forms: Mapping[str, BaseForm] = field(default_factory=dict)

    def __getitem__(self, name: str) -> Candidate:
        for c in self.candidates:
            if c.name == name:
                return c
        raise KeyError(name)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.candidates)

    def neutral_values(self) -> dict[str, float]:
        """Every library coefficient of a tyre property (not the nuisance ones) -> its
        neutral value."""
        out: dict[str, float] = {}
        for c in self.candidates:
            if not c.nuisance:
                out.update(c.coefficients)
        return out

    def for_problem(self, problem_name: str) -> tuple[Candidate, ...]:
        """The candidates whose relations match ``problem_name``."""
        return tuple(c for c in self.candidates if c.applies_to(problem_name))

    def merged(self, other: Library) -> Library:
        """This library with ``other``'s entries added (same name: ``other`` wins)."""
        theirs = {c.name for c in other.candidates}
        cands = tuple(c for c in self.candidates if c.name not in theirs) + other.candidates
        return Library(cands, {**self.forms, **other.forms})

    def only(self, names: Iterable[str]) -> Library:
        """A library restricted to the named candidates."""
        keep = set(names)
        return replace(self, candidates=tuple(c for c in self.candidates if c.name in keep))


def _number(value, where: str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(where, f"expected a finite number, not {value!r}", key=key)
    return float(value)


def _candidate(entry: Mapping, where: str) -> Candidate:
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip():
        raise InputError(where, "candidate without a name", key="candidate")
    missing = [k for k in _REQUIRED if k not in entry]
    if missing:
        raise InputError(where, f"missing {', '.join(missing)}", key=name)
    coefs = entry["coefficients"]
    if not isinstance(coefs, Mapping) or not coefs:
        raise InputError(where, "coefficients must be a non-empty table {KEY = neutral}",
                         key=name)
    coefs = {str(k).upper(): _number(v, where, f"{name}.{k}") for k, v in coefs.items()}
    raw_bounds = entry.get("bounds", {})
    if not isinstance(raw_bounds, Mapping):
        raise InputError(where, "bounds must be a table {KEY = [lower, upper]}", key=name)
    bounds: dict[str, tuple[float, float]] = {}
    for k, neutral in coefs.items():
        b = raw_bounds.get(k, raw_bounds.get(k.lower(), [neutral - 1.0, neutral + 1.0]))
        if not isinstance(b, (list, tuple)) or len(b) != 2:
            raise InputError(where, "bounds must be [lower, upper]", key=f"{name}.{k}")
        lo, hi = (_number(v, where, f"{name}.{k}") for v in b)
        if not lo <= neutral <= hi or lo == hi:
            raise InputError(where, f"bounds [{lo:g}, {hi:g}] must contain the neutral "
                                    f"value {neutral:g}", key=f"{name}.{k}")
        bounds[k] = (lo, hi)
    relations = entry["relations"]
    if isinstance(relations, str):
        relations = [relations]
    if not isinstance(relations, list) or not relations or not all(
            isinstance(r, str) for r in relations):
        raise InputError(where, "relations must be a non-empty list of problem names",
                         key=name)
    sign = str(entry.get("expected_sign", ""))
    if sign not in ("", "+", "-"):
        raise InputError(where, "expected_sign must be '+', '-' or ''", key=name)
    nuisance = entry.get("nuisance", False)
    if not isinstance(nuisance, bool):
        raise InputError(where, "nuisance must be true or false", key=name)
    return Candidate(name=name.strip(), coefficients=coefs, bounds=bounds,
                     relations=tuple(relations), equation=str(entry["equation"]),
                     description=str(entry["description"]), expected_sign=sign, source=where,
                     nuisance=nuisance)


def parse_library(text: str, where: str) -> Library:
    """Parse library TOML text (``where`` names it in errors).

    Raises
    ------
    InputError
        For malformed TOML or a malformed entry.
    """
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(where, f"malformed TOML: {exc}") from None
    entries = doc.get("candidate", [])
    if not isinstance(entries, list):
        raise InputError(where, "use [[candidate]] tables", key="candidate")
    cands = [_candidate(e, where) for e in entries]
    seen: set[str] = set()
    for c in cands:
        if c.name in seen:
            raise InputError(where, "duplicate candidate name", key=c.name)
        seen.add(c.name)
    forms = {}
    for name, f in (doc.get("forms") or {}).items():
        if not isinstance(f, Mapping) or "problems" not in f or "neutral" not in f:
            raise InputError(where, "a form needs problems = [...] and neutral = [...]",
                             key=f"forms.{name}")
        forms[name] = BaseForm(name, tuple(f["problems"]),
                               tuple(str(k).upper() for k in f["neutral"]),
                               str(f.get("description", "")))
    if not cands and not forms:
        raise InputError(where, "no [[candidate]] entries")
    return Library(tuple(cands), forms)


def load_library(extra: str | Path | None = None) -> Library:
    """The shipped library, extended by the user's TOML file ``extra`` when given.

    Raises
    ------
    InputError
        If ``extra`` is missing or malformed.
    """
    text = files("identify.discover").joinpath("library.toml").read_text(encoding="utf-8")
    lib = parse_library(text, "library")
    if extra is None:
        return lib
    path = Path(extra)
    if not path.is_file():
        raise InputError(path, "no such candidates file")
    try:
        user_text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read: {exc}") from None
    return lib.merged(parse_library(user_text, str(path)))
