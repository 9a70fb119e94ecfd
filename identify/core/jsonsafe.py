"""JSON for outputs: numpy scalars and arrays, paths and NaN made JSON-safe in one place."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def json_default(obj):
    """``default=`` hook for json.dumps: numpy numbers/arrays -> Python, paths -> str."""
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
