"""Rig simulator: complete simulated measurement folders with known truth.

``simulate_folder(tir_params, outdir, ...)`` writes Flatplank raw runs for every test type,
trailer sweeps, eigenfrequencies, ``tyre.toml`` and ``truth.json`` (docs/measurement-folder.md).
Modules: ``coefficients`` (default relations, thesis-calibrated), ``default_tyre`` (the bundled
225/50 R17 .tir), ``grid``, ``rig`` (constants and the hub-transform inverse), ``artefacts``,
``model`` (the simulated tyre), ``flatplank`` / ``flatplank_rolling`` / ``trailer`` (runs),
``truth`` (true characteristics), ``manifest`` and ``folder`` (writing).
"""
from identify.simulate.artefacts import Artefacts
from identify.simulate.coefficients import DEFAULT_RELATIONS, Relations
from identify.simulate.default_tyre import default_tir_path
from identify.simulate.folder import SimulationResult, simulate_folder
from identify.simulate.grid import FULL, SMALL, Grid
from identify.simulate.rig import DEFAULT_RIG, Rig

__all__ = ["simulate_folder", "SimulationResult", "Relations", "DEFAULT_RELATIONS", "Rig",
           "DEFAULT_RIG", "Grid", "FULL", "SMALL", "Artefacts", "default_tir_path"]
