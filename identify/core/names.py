"""Names that become file names: tyre ids and run ids are checked, never joined as given.

A tyre id names the fit directory (``fits/<id>/``), the .tir (``<id>.tir``) and the report
(``reports/<id>.pdf``), so an id such as ``"../../x"`` or ``""`` would write outside ``--out``
or a hidden file. An id is a *safe file name*: letters, digits, ``-``, ``_`` and ``.``; not
empty, not ``.`` or ``..``. Run files named in ``tyre.toml`` must lie inside the measurement
folder (:func:`inside`).
"""
from __future__ import annotations

import re
from pathlib import Path

from identify.core.errors import one_line

__all__ = ["NAME_RULE", "name_problem", "safe_name", "inside"]

_SAFE = re.compile(r"[\w.-]+")  # \w: any script's letters and digits, and _
#: How a safe name is described in messages.
NAME_RULE = "letters, digits, '-', '_' and '.' only; not empty, '.' or '..'"
#: Longest safe name [bytes of UTF-8] (file systems allow 255 bytes; the .tir adds 4).
MAX_LENGTH = 200


def name_problem(text: str) -> str | None:
    """Why ``text`` cannot be a file name (None when it can).

    >>> name_problem("225-50R17_v2") is None
    True
    >>> name_problem("../x").startswith("'../x' is not a safe file name")
    True
    """
    long = len(text.encode("utf-8", "surrogatepass")) > MAX_LENGTH
    if text in ("", ".", "..") or not _SAFE.fullmatch(text) or long:
        shown = text if len(text) <= 40 else text[:37] + "..."
        return f"{shown!r} is not a safe file name ({NAME_RULE}" + (
            f"; at most {MAX_LENGTH} bytes)" if long else ")")
    return None


def safe_name(text: str) -> str:
    """A safe file name made from any text: runs of other characters become ``-``, leading
    and trailing ``-``/``.`` are stripped (``"Hoosier 18.0x6.0-10 R25B"`` ->
    ``"Hoosier-18.0x6.0-10-R25B"``, ``"../a//b c"`` -> ``"a-b-c"``); ``""`` when nothing
    is left."""
    name = re.sub(r"[^\w.-]+", "-", text).strip("-.")
    while len(name.encode("utf-8", "surrogatepass")) > MAX_LENGTH:
        name = name[:-1]
    return name


def inside(folder: Path, relative: str) -> tuple[Path | None, str | None]:
    """The file ``relative`` names under ``folder``, resolved, when it lies inside the folder.

    Returns
    -------
    (Path, None) or (None, str)
        The resolved path, or why it is refused: an absolute path, a path that leaves the
        folder (``..``, or a symbolic link pointing outside), a symbolic-link loop.
    """
    if "\x00" in relative:  # no file system allows it: os.stat raises ValueError
        return None, f"'{one_line(relative, 60)}' holds a NUL byte, which no file name can"
    if Path(relative).is_absolute():
        return None, f"an absolute path is not allowed: {relative!r} (name a file inside the " \
                     "measurement folder, relative to it)"
    try:
        root = folder.resolve(strict=False)
        target = (folder / relative).resolve(strict=False)
    except (OSError, RuntimeError, ValueError) as exc:  # a loop: RuntimeError before 3.13
        return None, f"cannot resolve {relative!r}: {getattr(exc, 'strerror', None) or exc}"
    if not target.is_relative_to(root):
        return None, f"{relative!r} leads outside the measurement folder (to {target})"
    return target, None
