"""Tyre property files (.tir): :func:`read_tir` (real files as they come) and
:func:`write_tir` / :func:`format_tir` (complete MF 6.1/6.2 files)."""
from identify.io.tir.read import KNOWN_FITTYPS, SUPPORTED_FITTYPS, TirFile, read_tir
from identify.io.tir.write import format_tir, format_value, write_tir

__all__ = ["TirFile", "read_tir", "write_tir", "format_tir", "format_value",
           "SUPPORTED_FITTYPS", "KNOWN_FITTYPS"]
