"""mfid's Python API: the names a notebook needs, in one place (``import identify as mfid``, or
``import mfid``).

Load and inspect a folder, fit it, look at a result, plot it, write and evaluate a .tir, run
discovery, simulate a folder. Every function is the one the ``mfid`` command runs; the worked
example is docs/api.md (a test runs it).

=====================  ==========================================================================
``load_folder``        a measurement folder -> ``MeasurementSet`` (tidy SI tables, manifest)
``fit``                fit a folder or a ``MeasurementSet`` in memory -> ``FitRun`` (nothing
                       written; ``run.save(dir)`` writes it, ``FitRun.load(dir)`` reads it)
``fit_folder``         fit a folder, write ``out_root/<tyre id>/`` -> ``FitRun`` (the command)
``read_fit``           a fit directory -> ``FitRun`` (with the .tir values and per-point arrays)
``plot_fit``           one fit of a run -> matplotlib ``Figure`` (measured vs model, residuals,
                       errors, parameters: the report's page)
``write_report``       the PDF report of a fit directory
``discover_folder``    name the effect the model is missing -> ``DiscoveryRun``
``read_tir``           a .tir file -> ``TirFile`` (``.params()``: SI values)
``write_tir``          values -> a complete MF 6.1/6.2 .tir
``evaluate``           the forward model (a ``TirFile`` or a mapping of values) at arrays of
                       operating points -> dict of arrays
``simulate_folder``    a simulated measurement folder with known truth
``analyse_vehicle``    a .tir on a car at front/rear pressures -> ``VehicleResult`` (handling
                       diagram, understeer gradient, frequency response, ride; docs/vehicle.md)
``read_vehicle``       a vehicle file (TOML) -> ``VehicleSpec``; ``"default"``: the default sedan
=====================  ==========================================================================
"""
from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from identify.core.errors import FitError, InputError, MfidError
from identify.core.progress import Progress
from identify.core.version import __version__
from identify.fit.result import FitResult, MCMCSummary
from identify.fit.run import FitRun as _FitRun
from identify.fit.run import FitSettings
from identify.io.fitdir import JSON_NAME, FitDir, read_fit_dir, write_fit_dir
from identify.io.folder import MeasurementSet, load_folder
from identify.io.tir import TirFile, read_tir, write_tir
from identify.model.evaluate import evaluate as _evaluate
from identify.report.fit_pages import fit_pages
from identify.report.pdf import Report, write_report
from identify.simulate import simulate_folder
from identify.vehicle.analysis import VehicleOptions, VehicleResult
from identify.vehicle.spec import VehicleSpec, read_vehicle
from identify.workflows.discover import DiscoveryRun, discover_folder
from identify.workflows.fit import fit_folder as _fit_folder
from identify.workflows.fit import fit_measurements
from identify.workflows.vehicle import analyse_vehicle

__all__ = ["load_folder", "fit", "fit_folder", "read_fit", "plot_fit", "write_report",
           "discover_folder", "read_tir", "write_tir", "evaluate", "simulate_folder",
           "MeasurementSet", "FitRun", "FitResult", "FitSettings", "MCMCSummary", "TirFile",
           "DiscoveryRun", "Report", "MfidError", "InputError", "FitError", "__version__",
           "analyse_vehicle", "read_vehicle", "VehicleResult", "VehicleSpec", "VehicleOptions"]


class FitRun(_FitRun):
    """A fit of one measurement folder (:class:`identify.fit.run.FitRun`) that can be saved
    and loaded: ``run.save(dir)`` writes the fit directory (the .tir, fit.json,
    measured_vs_model.csv, extraction.json), ``FitRun.load(dir)`` reads one back with every
    result's points, so that ``run.table()``, ``run.plot(name)`` and ``result.params`` work
    the same on either."""

    def save(self, directory: str | Path, *, overwrite: bool = False) -> FitRun:
        """Write the fit directory ``directory`` and return the run with ``fit_dir`` set.

        Raises
        ------
        InputError
            ``directory`` already holds a fit (unless ``overwrite``) or cannot be written; the
            run has no points to write (a run read from fit.json alone).
        """
        directory = Path(directory)
        if (directory / JSON_NAME).exists() and not overwrite:
            raise InputError(directory, f"already holds a fit ({JSON_NAME}): give "
                                        "overwrite=True to replace it")
        if self.points is None:
            raise InputError(directory, "this run holds no points to write")
        return _as_api(write_fit_dir(self, directory, points=self.points,
                                     extraction=self.extraction))

    @classmethod
    def load(cls, directory: str | Path) -> FitRun:
        """A fit directory read back (``read_fit``)."""
        found = read_fit_dir(directory)
        return _as_api(dataclasses.replace(found.run, points=found.points,
                                           extraction=found.extraction))


def _as_api(run: _FitRun) -> FitRun:
    if isinstance(run, FitRun):
        return run
    return FitRun(**{f.name: getattr(run, f.name) for f in dataclasses.fields(_FitRun)})


def _settings_of(settings: FitSettings | None, only: Iterable[str],
                 options: dict[str, Any]) -> tuple[FitSettings, dict[str, float]]:
    """The FitSettings of a call (given whole, or as keywords with ``only``) and the nominal
    conditions of a single characteristics CSV among the keywords."""
    nominal = {k: options.pop(k) for k in ("nominal_pressure_Pa", "nominal_load_N")
               if k in options}
    if settings is None:
        return FitSettings(only=tuple(only), **options), nominal
    if options or only:
        raise TypeError("give settings or its fields as keywords, not both")
    return settings, nominal


def _notebook_progress() -> Progress | None:
    """A progress line that updates in place in a Jupyter notebook (the elapsed time and the
    current step), or None outside one."""
    shell = sys.modules.get("IPython")
    ip = getattr(shell, "get_ipython", lambda: None)() if shell else None
    if ip is None or not hasattr(ip, "kernel"):
        return None
    from IPython.display import display  # present wherever a kernel runs

    t0 = time.perf_counter()
    handle = display("[   0.0 s] starting", display_id=True)

    def show(text: str) -> None:
        handle.update(f"[{time.perf_counter() - t0:6.1f} s] {text}")

    return show


def fit(source: str | Path | MeasurementSet, *, settings: FitSettings | None = None,
        only: Iterable[str] = (), progress: Progress | bool | None = None,
        **options: Any) -> FitRun:
    """Fit a measurement folder, a characteristics CSV or a loaded ``MeasurementSet`` in
    memory, and write nothing.

    Parameters
    ----------
    source : path or MeasurementSet
    settings : FitSettings, optional
        Everything that makes a fit; or give its fields as keywords (``seed=1``,
        ``mcmc=True`` ...) and ``only=["CFx", "MF"]``.
    progress : callable, bool or None
        Called with one line per step. None: a line updating in place in a notebook, silent
        elsewhere; True: lines with the elapsed time on standard error; False: silent.
    **options
        FitSettings fields, and ``nominal_pressure_Pa``/``nominal_load_N`` for a single CSV.

    Returns
    -------
    FitRun
        ``run.save(dir)`` writes it; ``run.failed`` lists the fits that did not converge.
    """
    settings, nominal = _settings_of(settings, only, options)
    if progress is None:
        progress = _notebook_progress()
    elif progress is True:
        t0 = time.perf_counter()
        progress = (lambda text: print(f"[{time.perf_counter() - t0:6.1f} s] {text}",
                                       file=sys.stderr))
    elif progress is False:
        progress = None
    return _as_api(fit_measurements(source, settings=settings, progress=progress, **nominal))


def evaluate(params: TirFile | Mapping[str, Any], fz, kappa, alpha, gamma, vx, **kwargs
             ) -> dict[str, np.ndarray]:
    """The forward model at arrays of operating points (:func:`identify.model.evaluate.
    evaluate`); ``params`` is a ``TirFile`` (its SI values) or a mapping of .tir keys."""
    values = params.params() if isinstance(params, TirFile) else params
    return _evaluate(values, fz, kappa, alpha, gamma, vx, **kwargs)



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
    settings, nominal = _settings_of(settings, only, options)
    return _as_api(_fit_folder(source, out_root=out_root, settings=settings, **nominal))


def read_fit(path: str | Path | _FitRun) -> FitRun:
    """A fit directory (``fits/<tyre id>``) read back as a ``FitRun``, complete with the .tir
    values and each fit's measured and predicted points."""
    if isinstance(path, _FitRun):
        path = path.fit_dir
    return FitRun.load(path)


def plot_fit(run: FitRun | str | Path, name: str) -> Figure:
    """The report's page of one fit as a matplotlib ``Figure``.

    Parameters
    ----------
    run : FitRun or path
        A run that wrote its fit directory (``fit_folder``'s result) or the directory.
    name : str
        ``"CFx/quadratic_load"``, ``"MF/Fy0"``, or a relation with one fit (``"RR"``).
    """
    fd: FitDir = read_fit_dir(run.fit_dir if isinstance(run, _FitRun) else run)
    pages, _ = fit_pages(fd, fd.run.result(name))
    return pages[0][1]
