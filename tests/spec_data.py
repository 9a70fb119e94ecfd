"""Where the specification's reference data lives (../shared/spec beside the repository).

Only tests marked ``spec`` use it; they are skipped with a clear reason when it is absent.
"""
from __future__ import annotations

from pathlib import Path

import pytest

SPEC_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "spec"
GOLDEN_DIR = SPEC_DIR / "data" / "golden"
MFEVAL_DIR = SPEC_DIR / "data" / "mfeval"

needs_spec = pytest.mark.skipif(not SPEC_DIR.is_dir(),
                                reason=f"specification data not found at {SPEC_DIR}")
