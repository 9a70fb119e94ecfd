"""Real measurement sets beside the project (``../shared/realdata`` from the repository root).

They are never part of the repository (no licence lets us redistribute TTC data): tests that
use them are trials and skip when the folder is absent, so a user's clone stays complete.
"""
from __future__ import annotations

from pathlib import Path

import pytest

#: The folder of real sets: one sub-folder per set, its trailer files inside.
REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
#: File suffixes of trailer files a set may hold.
TRAILER_SUFFIXES = (".mat", ".dat", ".csv", ".h5", ".hdf5", ".tdx")


def real_sets() -> list[Path]:
    """The sets that hold trailer files (sorted; empty when the folder is absent)."""
    if not REALDATA.is_dir():
        return []
    return sorted(d for d in REALDATA.iterdir()
                  if d.is_dir() and trailer_files(d))


def trailer_files(folder: Path) -> list[Path]:
    """The trailer files of one set (a run's .dat beside its .mat is imported once)."""
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in TRAILER_SUFFIXES)


def require_realdata() -> None:
    """Skip the calling test when the real sets are not beside the project."""
    if not real_sets():
        pytest.skip(f"no real measurement sets at {REALDATA}")


#: ``pytest.mark.parametrize`` ids and values over the sets (one skipped case when absent).
SETS = real_sets() or [pytest.param(None, marks=pytest.mark.skip(
    reason=f"no real measurement sets at {REALDATA}"))]
