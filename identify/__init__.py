"""mfid: tyre-model parameter identification (Magic Formula 6.1/6.2 with inflation pressure).

Sub-packages follow the flow of the work, one stage each:
``load`` (files -> tidy tables), ``extract`` (raw runs -> characteristics), ``model`` (pure
forward-model equations), ``fit`` (optimisation and MCMC), ``discover`` (missing effects),
``report`` (.tir, JSON, PDF writers) and ``cli`` (the ``mfid`` command).
"""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("mfid")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
