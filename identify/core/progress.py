"""The progress callback of every long run (fit, discovery, report, import)."""
from __future__ import annotations

from collections.abc import Callable

__all__ = ["Progress"]

Progress = Callable[[str], None]
"""Called with one short line of text as each stage starts (the CLI shows it with rich)."""
