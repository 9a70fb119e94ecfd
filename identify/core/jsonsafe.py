"""JSON for outputs: the one place where numpy values, paths and NaN are made JSON-safe.

JSON has no NaN or infinity; every output of mfid writes an unknown or non-finite number as
``null``. :func:`json_safe` applies that rule (and turns numpy scalars and arrays, tuples and
paths into plain Python) to a whole document; :func:`json_float` is the same rule for one
number; :func:`json_text` is the text every JSON output file holds.
"""
from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["json_default", "json_float", "json_floats", "json_safe", "json_text"]


def json_safe(value: Any) -> Any:
    """``value`` as plain JSON data.

    Mappings become dicts with str keys, lists/tuples/arrays become lists, numpy scalars become
    Python scalars, paths become str, and a float that is NaN or infinite becomes None. Other
    values (str, int, bool, None) pass unchanged.
    """
    if isinstance(value, Mapping):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, PurePath):
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_float(x: Any) -> float | None:
    """One number for JSON: ``float(x)``, None for None, NaN or infinity."""
    return None if x is None else json_safe(float(x))


def json_floats(values: Mapping[Any, Any]) -> dict[str, float | None]:
    """A mapping of numbers for JSON: str keys, each value as :func:`json_float`."""
    return {str(k): json_float(v) for k, v in values.items()}


def json_text(doc: Any, *, indent: int = 1) -> str:
    """The JSON text of ``doc`` after :func:`json_safe` (strict: no NaN token can appear)."""
    return json.dumps(json_safe(doc), indent=indent, allow_nan=False)


def json_default(obj: Any) -> Any:
    """``default=`` hook for json.dumps (numpy numbers/arrays, paths); NaN is not reached by
    a hook, so prefer :func:`json_text`."""
    if isinstance(obj, (np.generic, np.ndarray, PurePath)):
        return json_safe(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
