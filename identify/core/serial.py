"""Versioned persistence of frozen dataclasses: one serializer over their fields, explicit
migrations between document versions.

:func:`to_data` writes a dataclass as a dict of its fields (``dataclasses.fields``, in
order), nested dataclasses as dicts, tuples as lists, mappings as dicts, then JSON-safe
(:func:`identify.core.jsonsafe.json_safe`: NaN as null). :func:`from_data` reads it back by
the fields' type hints: nested dataclasses, ``tuple[X, ...]``, ``X | None``, floats (null as
NaN for a ``float`` field), so ``from_data(C, to_data(c)) == c`` for the classes it serves.
A field missing from the data takes its default (a field added later reads as its default);
an unknown key is an error, never dropped silently.

A document carries its schema as ``"<name>/<version>"``. :class:`Schema` holds the current
version and one migration per older version (version k -> k + 1, a function of the plain
document); :meth:`Schema.upgrade` applies them in order, so a reader only knows the current
layout and an old file still loads through the migrations.
"""
from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable, Mapping
from typing import Any

from identify.core.jsonsafe import json_safe

__all__ = ["Schema", "from_data", "to_data"]


def _plain(obj: Any) -> Any:
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (tuple, list)):
        return [_plain(v) for v in obj]
    return obj


def to_data(obj: Any) -> Any:
    """A dataclass (and what it holds) as JSON-safe plain data, field by field."""
    return json_safe(_plain(obj))


def _read(hint: Any, value: Any) -> Any:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _read(inner[0], value)
        return value
    if dataclasses.is_dataclass(hint):
        return from_data(hint, value)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_read(args[0], v) for v in value or ())
        return tuple(_read(a, v) for a, v in zip(args, value, strict=True))
    if origin in (dict, Mapping) or hint in (dict, Mapping):
        vt = args[1] if len(args) == 2 else Any
        return {str(k): _read(vt, v) for k, v in (value or {}).items()}
    if hint is float:
        return math.nan if value is None else float(value)
    if hint in (int, str, bool):
        return hint(value)
    return value


def from_data(cls: type, data: Mapping[str, Any]) -> Any:
    """The ``cls`` instance that :func:`to_data` wrote as ``data``.

    Raises
    ------
    TypeError
        ``data`` is not a mapping or holds a key that is not a field of ``cls``.
    """
    if not isinstance(data, Mapping):
        raise TypeError(f"{cls.__name__}: expected a mapping, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise TypeError(f"{cls.__name__}: unknown field(s) {', '.join(unknown)}")
    hints = typing.get_type_hints(cls)
    return cls(**{name: _read(hints[name], data[name]) for name in fields if name in data})


@dataclasses.dataclass(frozen=True)
class Schema:
    """A document layout ``"<name>/<version>"`` and the migrations from its older versions.

    Attributes
    ----------
    name : str                     e.g. ``mfid.fit``
    version : int                  the version this code writes
    migrations : Mapping[int, Callable[[dict], dict]]   k -> the function that turns a
                                   version-k document into a version-(k+1) one
    """

    name: str
    version: int
    migrations: Mapping[int, Callable[[dict], dict]] = dataclasses.field(default_factory=dict)

    @property
    def tag(self) -> str:
        """The schema string this code writes."""
        return f"{self.name}/{self.version}"

    def version_of(self, doc: Any) -> int | None:
        """The version of a document of this schema, None when it is not one."""
        tag = doc.get("schema") if isinstance(doc, Mapping) else None
        if not isinstance(tag, str) or not tag.startswith(self.name + "/"):
            return None
        try:
            return int(tag[len(self.name) + 1:])
        except ValueError:
            return None

    def upgrade(self, doc: Mapping[str, Any]) -> dict[str, Any]:
        """``doc`` migrated to :attr:`version` (a new dict; ``doc`` is not modified).

        Raises
        ------
        ValueError
            Not a document of this schema, newer than this code, or of a version no
            migration starts from.
        """
        version = self.version_of(doc)
        if version is None or version > self.version or (
                version < self.version and any(k not in self.migrations
                                               for k in range(version, self.version))):
            found = doc.get("schema") if isinstance(doc, Mapping) else type(doc).__name__
            raise ValueError(f"schema is {found!r}, expected {self.tag!r}")
        out = dict(doc)
        for k in range(version, self.version):
            out = self.migrations[k](out)
            out["schema"] = f"{self.name}/{k + 1}"
        return out
