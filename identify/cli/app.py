"""The ``mfid`` command line (typer).

Conventions: one command per verb; user errors are one line on stderr and exit 2; a failed fit
exits 1; ``--debug`` shows the traceback. Outputs are written to a temporary name and renamed.
"""
from __future__ import annotations

import importlib
import sys

import click
import typer
from rich.console import Console
from typer.core import TyperGroup

from identify.core.errors import MfidError, one_line
from identify.core.version import __version__

COMMANDS = {"check": "check_cmd", "import": "import_cmd", "convert": "convert_cmd",
            "extract": "extract_cmd", "fit": "fit_cmd", "report": "report_cmd",
            "discover": "discover_cmd", "batch": "batch_cmd", "eval": "eval_cmd",
            "simulate": "simulate_cmd", "vehicle": "vehicle_cmd"}
"""Command name -> the module of identify.cli that registers it on :data:`app`, in --help order."""


class LazyCommands(TyperGroup):
    """The root group: a command's module is imported when the command is asked for.

    Each ``*_cmd`` module imports its whole stack (numpy, scipy, pandas, numba, matplotlib) at
    its top. Importing all of them takes about 1.6 s against 0.15 s for this module (measured:
    ``/usr/bin/time python -c 'import identify.workflows.fit'`` against ``identify.cli.app``),
    so ``mfid --version`` and ``mfid check`` would pay for ``mfid fit``'s imports; this is the
    one place where the CLI imports late, on purpose.
    """

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS) + [n for n in super().list_commands(ctx) if n not in COMMANDS]

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name in COMMANDS and name not in self.commands:
            importlib.import_module(f"identify.cli.{COMMANDS[name]}")
            # the commands register on this module's app as imported by name (not __main__
            # under ``python -m identify.cli.app``)
            registry = importlib.import_module("identify.cli.app").app
            info = next(c for c in registry.registered_commands if c.name == name)
            self.add_command(typer.main.get_command_from_info(
                info, pretty_exceptions_short=registry.pretty_exceptions_short,
                rich_markup_mode=registry.rich_markup_mode), name)
        return super().get_command(ctx, name)


app = typer.Typer(cls=LazyCommands, no_args_is_help=True, add_completion=False,
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
    err_console.print(f"error: {one_line(str(exc), 2000)}", markup=False)
    raise typer.Exit(exc.exit_code)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
