"""Atomic output, the one writer every module uses: a file is written as a temporary file in
the target's directory, fsynced and renamed onto the target; a folder is built beside its target
and renamed into place.

A reader (or ``make``) never sees a half-written output: the target either keeps its old
content or gets the complete new one. A failed write leaves no temporary file behind.

A folder is written the same way (:func:`temp_dir`, then :func:`replace_dir`): built in a
temporary folder next to it and renamed into place; the folder it replaces is moved aside
first and put back if the rename fails, so the target is the old folder or the new one,
never neither.

A temporary (file or folder) is named ``.<target name>.<pid>.<random>.tmp``. A process killed
outright (SIGKILL, a power cut) cannot remove its own, so the next write of the same target
removes the temporaries of that target whose writing process no longer runs: only entries of
this naming pattern, only next to the target, never one a running process is writing.
"""
from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from identify.core.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["atomic_path", "atomic_write_text", "atomic_write_bytes", "atomic_write_csv",
           "remove_stale", "replace_dir", "temp_dir"]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_MODE = 0o666 & ~_umask()


def _running(pid: int) -> bool:
    """True when process ``pid`` exists (on this machine)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True  # exists, owned by another user; or cannot tell: keep its file
    return True


def remove_stale(target: str | Path) -> list[Path]:
    """Remove the temporaries of ``target`` left by a writer that no longer runs.

    Only files and folders next to ``target`` named ``.<target name>.<pid>.<8
    characters>.tmp`` (this module's pattern) whose ``pid`` is not a running process are
    removed (a symbolic link is never followed). Returns them.
    """
    target = Path(target)
    pattern = re.compile(rf"\.{re.escape(target.name)}\.(\d{{1,10}})\.[A-Za-z0-9_]{{8}}\.tmp")
    removed = []
    try:
        names = os.listdir(target.parent)
    except OSError:
        return removed
    for name in names:
        match = pattern.fullmatch(name)
        if match is None or _running(int(match.group(1))):
            continue
        path = target.parent / name
        try:
            if path.is_symlink():
                continue
            if path.is_file():
                path.unlink()
                removed.append(path)
            elif path.is_dir():
                shutil.rmtree(path)
                removed.append(path)
        except OSError:
            pass
    return removed


def temp_dir(target: str | Path) -> Path:
    """A new empty folder next to ``target``, named as this module's temporaries, after the
    stale temporaries of ``target`` are removed (:func:`remove_stale`).

    The caller removes it on failure (``shutil.rmtree`` in an ``except BaseException``, so
    that Ctrl-C and SIGTERM, raised as exceptions by identify.cli.entry, remove it too), or
    hands it to :func:`replace_dir`.

    Raises
    ------
    InputError
        The folder cannot be made (a missing or read-only parent).
    """
    target = Path(target)
    try:
        remove_stale(target)
        return Path(tempfile.mkdtemp(prefix=f".{target.name}.{os.getpid()}.", suffix=".tmp",
                                     dir=target.parent))
    except OSError as exc:
        raise InputError(target, f"cannot write folder: {exc.strerror or exc}") from None


def replace_dir(tmp: str | Path, target: str | Path) -> Path:
    """Rename the complete folder ``tmp`` onto ``target``, replacing a folder there.

    The old ``target`` is moved aside into a temporary folder first and removed once the new
    one is in place; if the rename fails (or is interrupted) it is moved back. The caller
    removes ``tmp`` on failure. Returns ``target``.
    """
    tmp, target = Path(tmp), Path(target)
    if not target.exists():
        os.rename(tmp, target)
        return target
    trash = temp_dir(target)
    try:
        os.rename(target, trash / "old")
        try:
            os.rename(tmp, target)
        except BaseException:
            os.rename(trash / "old", target)
            raise
    finally:
        shutil.rmtree(trash, ignore_errors=True)
    return target


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Give a temporary path next to ``path``; on success rename it onto ``path``.

    For writers that need a file name (HDF5, PDF): write the complete file to the yielded
    path inside the ``with`` block. On any exception (including KeyboardInterrupt) the
    temporary file is removed and the target keeps its old content; an OSError becomes an
    :class:`InputError` naming the target.
    """
    target = Path(path)
    directory = target.parent
    try:
        mode = target.stat().st_mode & 0o777 if target.exists() else _MODE
        remove_stale(target)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=".tmp",
                                   dir=directory)
        os.close(fd)
    except OSError as exc:
        raise InputError(target, f"cannot write file: {exc.strerror or exc}") from None
    try:
        yield Path(tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise InputError(target, f"cannot write file: {exc.strerror or exc}") from None
        raise
    try:  # make the rename itself durable; not possible on every platform
        dir_fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)


def atomic_write_text(path: str | Path, text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (temp file + fsync + ``os.replace``).

    Line ends are written as given (no newline translation).

    Raises
    ------
    InputError
        If the file cannot be written (missing directory, permission ...).
    """
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding=encoding, newline="") as fh:
            fh.write(text)
    return Path(path)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temp file + fsync + ``os.replace``).

    Raises
    ------
    InputError
        If the file cannot be written (missing directory, permission ...).
    """
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)
    return Path(path)


def atomic_write_csv(df: pd.DataFrame, path: str | Path, **to_csv: Any) -> Path:
    """Write a DataFrame as CSV atomically, floats in shortest round-trip form.

    Parameters
    ----------
    df : pandas.DataFrame
        Table to write.
    path : str or Path
        Target file.
    **to_csv
        Extra arguments for :meth:`pandas.DataFrame.to_csv` (default ``index=False``).

    Returns
    -------
    Path
        The target path.
    """
    options = {"index": False, "float_format": None, "lineterminator": "\n"}
    options.update(to_csv)
    return atomic_write_text(path, df.to_csv(**options))
