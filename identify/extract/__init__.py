"""Characteristic extraction: raw Flatplank runs -> the characteristics the relations are fitted
to (CFz, CFx, CFy, CMz, sigma_y, Re, Fy_gamma, Mz_gamma, Mx_gamma; eigenfrequencies passed
through), with per-run diagnostics and flags for the test engineer.

Modules: ``runs`` (the tidy table cut into runs with their conditions), ``linear`` (line fits and
the automatic linear window), one module per test type (``vertical``, ``stiffness``,
``parking``, ``relaxation``, ``rolling``, ``camber``, ``eigen``), ``flags`` (thresholds and
shared checks), ``diagnostics`` (the fixed result records) and ``extract`` (``extract_folder``).
"""
from identify.extract.diagnostics import FLAG_NAMES, Flag, RunDiagnostic
from identify.extract.extract import COLUMNS, SCHEMA, Extraction, extract_folder
from identify.extract.flags import Thresholds

__all__ = ["extract_folder", "Extraction", "Thresholds", "RunDiagnostic", "Flag", "FLAG_NAMES",
           "COLUMNS", "SCHEMA"]
