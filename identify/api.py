"""mfid's Python API: the names a notebook needs, in one place (``import identify as mfid``, or
``import mfid``).

Load and inspect a folder, fit it, look at a result, plot it, write and evaluate a .tir, run
discovery, simulate a folder. Every function is the one the ``mfid`` command runs; the worked
example is docs/api.md (a test runs it).

=====================  ==========================================================================
``load_folder``        a measurement folder -> ``MeasurementSet`` (tidy SI tables, manifest)
``fit_folder``         fit a folder, write ``out_root/<tyre id>/`` -> ``FitRun``
``read_fit``           a fit directory -> ``FitRun`` (with the .tir values and per-point arrays)
``plot_fit``           one fit of a run -> matplotlib ``Figure`` (measured vs model, residuals,
                       errors, parameters: the report's page)
``write_report``       the PDF report of a fit directory
``discover_folder``    name the effect the model is missing -> ``DiscoveryRun``
``read_tir``           a .tir file -> ``TirFile`` (``.params()``: SI values)
``write_tir``          values -> a complete MF 6.1/6.2 .tir
``evaluate``           the forward model at arrays of operating points -> dict of arrays
``simulate_folder``    a simulated measurement folder with known truth
``analyse_vehicle``    a .tir on a car at front/rear pressures -> ``VehicleResult`` (handling
                       diagram, understeer gradient, frequency response, ride; docs/vehicle.md)
``read_vehicle``       a vehicle file (TOML) -> ``VehicleSpec``; ``"default"``: the default sedan
=====================  ==========================================================================
"""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from identify.core.errors import FitError, InputError, MfidError
from identify.core.version import __version__
from identify.fit.result import FitResult, MCMCSummary
from identify.fit.run import FitRun, FitSettings
from identify.io.fitdir import FitDir, read_fit_dir
from identify.io.folder import MeasurementSet, load_folder
from identify.io.tir import TirFile, read_tir, write_tir
from identify.model.evaluate import evaluate
from identify.report.fit_pages import fit_pages
from identify.report.pdf import Report, write_report
from identify.simulate import simulate_folder
from identify.workflows.discover import DiscoveryRun, discover_folder
from identify.workflows.fit import fit_folder as _fit_folder
from identify.workflows.vehicle import analyse_vehicle
from identify.vehicle.analysis import VehicleOptions, VehicleResult
from identify.vehicle.spec import VehicleSpec, read_vehicle

__all__ = ["load_folder", "fit_folder", "read_fit", "plot_fit", "write_report",
           "discover_folder", "read_tir", "write_tir", "evaluate", "simulate_folder",
           "MeasurementSet", "FitRun", "FitResult", "FitSettings", "MCMCSummary", "TirFile",
           "DiscoveryRun", "Report", "MfidError", "InputError", "FitError", "__version__",
           "analyse_vehicle", "read_vehicle", "VehicleResult", "VehicleSpec", "VehicleOptions"]


def fit_folder(source: str | Path, *, out_root: str | Path = "fits",
               settings: FitSettings | None = None, only: Iterable[str] = (),
               **options: Any) -> FitRun:
    """Fit a measurement folder (or one characteristics CSV) and write ``out_root/<id>/``.

    Parameters
    ----------
    source : path
        Measurement folder with a tyre.toml, the tyre.toml, or a characteristics CSV.
    out_root : path
        Root of the fit directories.
    settings : FitSettings, optional
        Everything that makes a fit; or give its fields as keywords (``seed=1``,
        ``mcmc=True`` ...) and ``only=["CFx", "MF"]``.
    **options
        FitSettings fields, and ``nominal_pressure_Pa``/``nominal_load_N`` for a single CSV.

    Returns
    -------
    FitRun
        ``run.failed`` lists the fits that did not converge (outputs are written anyway).
    """
    nominal = {k: options.pop(k) for k in ("nominal_pressure_Pa", "nominal_load_N")
               if k in options}
    if settings is None:
        settings = FitSettings(only=tuple(only), **options)
    elif options or only:
        raise TypeError("give settings or its fields as keywords, not both")
    return _fit_folder(source, out_root=out_root, settings=settings, **nominal)


def read_fit(path: str | Path | FitRun) -> FitRun:
    """A fit directory (``fits/<tyre id>``) read back as a ``FitRun``, complete with the .tir
    values and each fit's measured and predicted points."""
    if isinstance(path, FitRun):
        path = path.fit_dir
    return read_fit_dir(path).run


def plot_fit(run: FitRun | str | Path, name: str) -> Figure:
    """The report's page of one fit as a matplotlib ``Figure``.

    Parameters
    ----------
    run : FitRun or path
        A run that wrote its fit directory (``fit_folder``'s result) or the directory.
    name : str
        ``"CFx/quadratic_load"``, ``"MF/Fy0"``, or a relation with one fit (``"RR"``).
    """
    fd: FitDir = read_fit_dir(run.fit_dir if isinstance(run, FitRun) else run)
    pages, _ = fit_pages(fd, fd.run.result(name))
    return pages[0][1]
