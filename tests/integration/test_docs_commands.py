"""docs/commands.md lists every command of ``mfid`` with exactly the options ``mfid CMD --help``
shows: the option tables between ``<!-- options: CMD -->`` and ``<!-- /options -->`` are made by
:func:`options_table` from the command line itself, so a renamed, added or dropped option makes
this test fail instead of leaving the reference wrong.

Regenerate the tables after changing an option: ``python tests/integration/test_docs_commands.py
--write``.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import click
import typer

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "commands.md"
BLOCK = re.compile(r"(<!-- options: (\w+) -->\n)(.*?)(<!-- /options -->)", re.S)


def commands() -> dict[str, click.Command]:
    """Command name -> its click command, in ``mfid --help`` order."""
    from identify.cli.app import COMMANDS, app

    group = typer.main.get_command(app)
    ctx = click.Context(group)
    return {name: group.get_command(ctx, name) for name in COMMANDS}


def _cell(text: str) -> str:
    """One table cell: one line, rich's escaped brackets plain, pipes escaped."""
    return " ".join(text.split()).replace("\\[", "[").replace("|", "\\|")


def _default(p) -> str:
    value = p.default
    if p.param_type_name != "option" or not p.show_default:
        return ""
    if getattr(p, "is_flag", False):  # an on/off pair says which; a lone flag is off
        return ("on" if value else "off") if p.secondary_opts else ""
    if value is None or value == "" or isinstance(value, (list, tuple)):
        return ""
    return _cell(str(getattr(value, "value", value)))


def options_table(cmd) -> str:
    """The markdown table of a command's arguments and options, as its --help gives them."""
    ctx = type(cmd).context_class(cmd) if hasattr(cmd, "context_class") else None
    rows = ["| argument / option | value | meaning | default |", "|---|---|---|---|"]
    for p in cmd.params:
        if p.name == "help":
            continue
        argument = p.param_type_name == "argument"
        if argument:  # named as in the usage line, its type in the value column
            name = (p.metavar or p.name.upper()) + (" ..." if p.nargs == -1 else "")
        else:
            name = ", ".join(f"`{o}`" for o in [*p.opts, *p.secondary_opts])
        flag = getattr(p, "is_flag", False)
        typed = re.sub(r"^list\[(\w+)\]$", r"\1", p.display_type(ctx).strip("<>"))
        shown = typed.lower() if argument or not p.metavar else p.metavar
        value = "" if flag else _cell(shown)
        rows.append(f"| {name} | {value} | {_cell(p.help or '')} | {_default(p)} |")
    return "\n".join(rows) + "\n"


def test_every_command_has_its_options_table():
    text = DOC.read_text(encoding="utf-8")
    found = {m.group(2): m.group(3) for m in BLOCK.finditer(text)}
    cmds = commands()
    assert sorted(found) == sorted(cmds), "docs/commands.md: one options block per command"
    for name, cmd in cmds.items():
        assert found[name] == options_table(cmd), (
            f"docs/commands.md: the options of 'mfid {name}' are stale; "
            "run python tests/integration/test_docs_commands.py --write")


def _write() -> None:
    cmds = commands()
    text = DOC.read_text(encoding="utf-8")
    DOC.write_text(BLOCK.sub(lambda m: m.group(1) + options_table(cmds[m.group(2)]) + m.group(4),
                             text), encoding="utf-8")


if __name__ == "__main__" and "--write" in sys.argv:
    _write()
