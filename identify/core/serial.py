"""Versioned persistence of frozen dataclasses: one serializer over their fields, explicit
migrations between document versions.

:func:`to_data` writes a dataclass as a dict of its fields (``dataclasses.fields``, in
order), nested dataclasses as dicts, tuples as lists, mappings as dicts, enums as their
values, numpy arrays and scalars as lists and numbers, then JSON-safe
(:func:`identify.core.jsonsafe.json_safe`: a NaN or infinite number as null).
:func:`from_data` reads it back by the fields' type hints: nested dataclasses,
``tuple[X, ...]``, ``dict[K, V]``, ``X | None``, enums, ``np.ndarray`` (float), floats (null as
NaN for a ``float`` field, or the value the field's :func:`meta` names), so
``from_data(C, to_data(c)) == c`` for the classes it serves. A field missing from the data
takes its default (a field added later reads as its default; a field without a default is
an error); an unknown key, or a null where the field's type allows none, is an error naming
the class and key, never dropped or coerced silently.

A class says where its document differs from its fields, and nothing else:

- :func:`meta` on a field (``field(metadata=meta(...))``): the key it is written under, a
  field that is not written (kept in memory only, e.g. per-point arrays), what a null reads
  as, and the format of number keys;
- ``serial_derived`` (a class attribute): keys written after the fields, each a function of
  the object (a printed line, a count); they are derived, so reading ignores them;
- ``serial_order`` (a class attribute): the keys written first, in this order (the others
  follow in field order), where a document's key order predates its class's field order.

A class whose document has a shape of its own for some fields keeps a small ``from_dict``
that reads those and passes them to :func:`from_data` (its ``given`` values); legacy
readings of a record go into explicit defaults of that hook or into the document's
migrations. A nested dataclass is written by its own ``to_dict`` and read by its own
``from_dict`` when it has them, so one class's hook holds wherever it is nested.
:class:`Serial` gives a dataclass ``to_dict``/``from_dict`` that are
:func:`to_data`/:func:`from_data`.

A document carries its schema as ``"<name>/<version>"``. :class:`Schema` holds the current
version and one migration per older version (version k -> k + 1, a function of the plain
document); :meth:`Schema.upgrade` applies them in order, so a reader only knows the current
layout and an old file still loads through the migrations.
"""
from __future__ import annotations

import dataclasses
import enum
import functools
import math
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from identify.core.jsonsafe import json_safe

__all__ = ["Schema", "Serial", "from_data", "meta", "to_data"]

_KEY = "serial_key"
_SKIP = "serial_skip"
_NULL = "serial_null"
_KEY_FORMAT = "serial_key_format"


def meta(*, key: str | None = None, skip: bool = False, null: float | None = None,
         key_format: str | None = None) -> dict[str, Any]:
    """A field's serial metadata, for ``dataclasses.field(metadata=...)``.

    Parameters
    ----------
    key : str, optional   the document key of the field (default: its name)
    skip : bool           not written, and read as its default (data kept in memory only)
    null : float, optional   what a null reads as for a float field (default NaN), e.g.
                          ``math.inf`` for a quantity whose null means unbounded
    key_format : str, optional   ``format`` spec of the keys of a mapping field with number
                          keys (e.g. ``"g"``: a pressure of 2.0 bar as ``"2"``); read back by
                          the key type
    """
    out: dict[str, Any] = {}
    if key is not None:
        out[_KEY] = key
    if skip:
        out[_SKIP] = True
    if null is not None:
        out[_NULL] = float(null)
    if key_format is not None:
        out[_KEY_FORMAT] = key_format
    return out


@functools.cache
def _layout(cls: type) -> tuple[tuple[str, str, Any, float], ...]:
    """(attribute, key, type hint, null value) of every written field of ``cls``."""
    hints = typing.get_type_hints(cls)
    return tuple((f.name, f.metadata.get(_KEY, f.name), hints[f.name],
                  f.metadata.get(_NULL, math.nan))
                 for f in dataclasses.fields(cls) if not f.metadata.get(_SKIP))


@functools.cache
def _key_formats(cls: type) -> Mapping[str, str]:
    return {f.name: f.metadata[_KEY_FORMAT] for f in dataclasses.fields(cls)
            if _KEY_FORMAT in f.metadata}


def _derived(cls: type) -> Mapping[str, Callable[[Any], Any]]:
    return getattr(cls, "serial_derived", None) or {}


def _fields_plain(obj: Any) -> dict[str, Any]:
    formats = _key_formats(type(obj))
    out = {}
    for name, key, _, _ in _layout(type(obj)):
        value = getattr(obj, name)
        if name in formats:
            value = {format(k, formats[name]): v for k, v in value.items()}
        out[key] = _plain(value)
    out.update({key: _plain(fn(obj)) for key, fn in _derived(type(obj)).items()})
    order = getattr(type(obj), "serial_order", ())
    if order:
        out = {**{k: out[k] for k in order}, **out}
    return out


def _plain(obj: Any) -> Any:
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        to_dict = getattr(obj, "to_dict", None)
        return to_dict() if callable(to_dict) else _fields_plain(obj)
    if isinstance(obj, enum.Enum):
        return obj.value
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (tuple, list)):
        return [_plain(v) for v in obj]
    return obj


def to_data(obj: Any) -> Any:
    """A dataclass (and what it holds) as JSON-safe plain data, field by field (the class's
    :func:`meta` and ``serial_derived`` applied; a nested dataclass by its own ``to_dict``)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return json_safe(_fields_plain(obj))
    return json_safe(_plain(obj))


def _read(hint: Any, value: Any, null: float = math.nan) -> Any:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _read(inner[0], value, null)
        return value
    if value is None and hint is not float and hint is not Any:
        raise TypeError(f"null where {getattr(hint, '__name__', hint)} is expected")
    if dataclasses.is_dataclass(hint):
        from_dict = getattr(hint, "from_dict", None)
        return from_dict(value) if callable(from_dict) else from_data(hint, value)
    if hint is tuple:
        return tuple(value)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_read(args[0], v, null) for v in value)
        return tuple(_read(a, v, null) for a, v in zip(args, value, strict=True))
    if origin in (list, Sequence) or hint is list:
        return [_read(args[0] if args else Any, v, null) for v in value]
    if origin in (dict, Mapping) or hint in (dict, Mapping):
        kt, vt = args if len(args) == 2 else (str, Any)
        return {_read(kt, k): _read(vt, v, null) for k, v in value.items()}
    if hint is float:
        return null if value is None else float(value)
    if hint in (int, str, bool, Path):
        return hint(value)
    if hint is np.ndarray:
        return np.asarray(value, dtype=float)
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return hint(value)
    return value


def from_data(cls: type, data: Mapping[str, Any], **given: Any) -> Any:
    """The ``cls`` instance that :func:`to_data` wrote as ``data``.

    ``given`` holds values of fields a class's own hook reads (a field that is not written,
    or one written in a shape of its own): they are passed as they are, and their keys in
    ``data`` are not read.

    Raises
    ------
    TypeError
        ``data`` is not a mapping, holds a key that is neither a written field nor a derived
        key of ``cls``, lacks a field that has no default, or holds a value its field's type
        cannot take (a null where no null is allowed); the message names the class and key.
    """
    if not isinstance(data, Mapping):
        raise TypeError(f"{cls.__name__}: expected a mapping, got {type(data).__name__}")
    given_keys = {key for name, key, _, _ in _layout(cls) if name in given} | set(given)
    layout = tuple(entry for entry in _layout(cls) if entry[0] not in given)
    keys = {key for _, key, _, _ in layout}
    unknown = sorted(set(data) - keys - set(_derived(cls)) - given_keys)
    if unknown:
        raise TypeError(f"{cls.__name__}: unknown field(s) {', '.join(map(str, unknown))}")
    required = {f.name for f in dataclasses.fields(cls) if f.init
                and f.default is dataclasses.MISSING
                and f.default_factory is dataclasses.MISSING}
    missing = sorted(key for name, key, _, _ in layout if name in required and key not in data)
    missing += sorted(name for name in required - set(given)
                      if name not in {entry[0] for entry in layout})
    if missing:
        raise TypeError(f"{cls.__name__}: missing field(s) {', '.join(missing)}")
    values = dict(given)
    for name, key, hint, null in layout:
        if key in data:
            try:
                values[name] = _read(hint, data[key], null)
            except (TypeError, ValueError, AttributeError) as exc:
                raise TypeError(f"{cls.__name__}.{key}: {exc}") from None
    return cls(**values)


class Serial:
    """Mixin of a dataclass written and read field by field: ``to_dict`` is :func:`to_data`,
    ``from_dict`` is :func:`from_data`."""

    __slots__ = ()

    def to_dict(self) -> dict[str, Any]:
        """The JSON-safe dict of the fields (identify.core.serial)."""
        return to_data(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Any:
        """Inverse of :meth:`to_dict` (identify.core.serial.from_data)."""
        return from_data(cls, d)


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
