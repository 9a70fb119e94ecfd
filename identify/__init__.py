"""mfid: tyre-model parameter identification (Magic Formula 6.1/6.2 with inflation pressure).

The public API is :mod:`identify.api`; its names are available here (``identify.fit_folder``,
``identify.read_tir`` ...) and under ``import mfid``. Sub-packages follow the flow of the work,
one stage each, in layers (import-linter contract in pyproject.toml): ``core`` < ``model`` <
``fit`` | ``extract`` | ``segment`` < ``io`` < ``simulate`` | ``vehicle`` < ``discover`` <
``report`` < ``workflows`` < ``cli`` | ``api``.
"""

_API = ("load_folder", "fit_folder", "read_fit", "plot_fit", "write_report",
        "discover_folder", "read_tir", "write_tir", "evaluate", "simulate_folder",
        "MeasurementSet", "FitRun", "FitResult", "FitSettings", "MCMCSummary", "TirFile",
        "DiscoveryRun", "Report",
        "MfidError", "InputError", "FitError", "analyse_vehicle", "read_vehicle",
        "VehicleResult", "VehicleSpec", "VehicleOptions")

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    # the API pulls in numpy, scipy, pandas and matplotlib (~1.5 s): imported on first use so
    # that `mfid --version`, and the CLI's signal handlers, come before that cost
    if name in _API:
        from identify import api

        return getattr(api, name)
    if name == "__version__":
        # importlib.metadata takes 20-90 ms (python -X importtime -c "import identify"): the
        # console script's signal handlers (identify.cli.entry) must come before that
        from identify.core.version import __version__

        return __version__
    raise AttributeError(f"module 'identify' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
