"""The ``mfid`` command line (typer).

Conventions: one command per verb; user errors are one line on stderr and exit 2; a failed fit
exits 1; ``--debug`` shows the traceback. Outputs are written to a temporary name and renamed.
"""
from __future__ import annotations

import sys

import typer
from rich.console import Console

from identify.core.version import __version__
from identify.core.errors import MfidError

app = typer.Typer(no_args_is_help=True, add_completion=False,
                  help="mfid: Magic Formula tyre-model identification workbench.")
err_console = Console(stderr=True, highlight=False, soft_wrap=True)
out_console = Console(highlight=False, soft_wrap=True)

_STATE = {"debug": False}


def _version_callback(value: bool) -> None:
    if value:
        out_console.print(f"mfid {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version_callback, is_eager=True,
                                 help="Print the mfid version and exit."),
    debug: bool = typer.Option(False, "--debug", help="Show tracebacks for errors."),
) -> None:
    """mfid: identify Magic Formula 6.1/6.2 tyre models with inflation pressure."""
    _STATE["debug"] = debug


def fail(exc: MfidError) -> None:
    """Print a user error as one line on stderr and exit with its code."""
    if _STATE["debug"]:
        raise exc
    err_console.print(f"error: {exc}", markup=False)
    raise typer.Exit(exc.exit_code)


# Commands register themselves on `app` when their modules are imported.
from identify.cli import eval_cmd  # noqa: E402,F401
from identify.cli import simulate_cmd  # noqa: E402,F401
from identify.cli import check_cmd, convert_cmd  # noqa
from identify.cli import fit_cmd, report_cmd  # noqa: E402,F401
from identify.cli import extract_cmd  # noqa
from identify.cli import discover_cmd  # noqa: E402,F401
from identify.cli import batch_cmd  # noqa: E402,F401
from identify.cli import import_cmd  # noqa: E402,F401


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
