"""Outputs never harm inputs: the one check every command makes before any work.

A command reads files and folders (a measurement folder, a .tir, a table of operating points,
a fit directory) and writes outputs. An output that *is* an input (``mfid eval T.tir --input
pts.csv --output pts.csv``), that lies inside an input folder (``mfid fit F --out F``:
the measurement folder is only ever read), or that holds an input (``mfid import run.csv
--out . --overwrite``, which would clear the folder the input is in) is refused, whatever the
spelling: paths are compared resolved (``..``, symbolic links) and files also by identity
(hard links). An output of the wrong kind (a directory where a file is written, a regular
file where a folder is made) is refused as well, so that a command fails before its work and
leaves nothing behind, not after it.
"""
from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from identify.core.errors import InputError
from identify.fit.run import CSV_NAME, JSON_NAME
from identify.io.fitdir import EXTRACTION_NAME

__all__ = ["Inputs", "check_file_output", "check_files_in", "check_fit_outputs",
           "check_folder_output", "measurement_inputs"]


@dataclass(frozen=True)
class Inputs:
    """What a command reads: ``files`` (each only read) and ``folders`` (read as a whole:
    nothing may be written inside them)."""

    files: tuple[Path, ...] = ()
    folders: tuple[Path, ...] = ()

    @classmethod
    def of(cls, files: Iterable[str | Path | None] = (),
           folders: Iterable[str | Path | None] = ()) -> Inputs:
        """The inputs, None entries left out (an option not given)."""
        return cls(tuple(Path(f) for f in files if f is not None),
                   tuple(Path(d) for d in folders if d is not None))

    def __add__(self, other: Inputs) -> Inputs:
        return Inputs(self.files + other.files, self.folders + other.folders)


def measurement_inputs(source: str | Path) -> Inputs:
    """The inputs of a measurement source as ``check``, ``fit`` and ``discover`` take it: a
    folder, or its ``tyre.toml``, is the folder; a single file (a characteristics CSV) is
    that file alone."""
    source = Path(source)
    if source.is_dir():
        return Inputs(folders=(source,))
    if source.name == "tyre.toml":
        return Inputs(files=(source,), folders=(source.parent,))
    return Inputs(files=(source,))


def _resolve(path: Path, key: str | None) -> Path:
    try:
        return path.resolve(strict=False)
    except (OSError, RuntimeError, ValueError) as exc:  # a link loop, a NUL byte
        raise InputError(path, f"cannot resolve the output path: "
                               f"{getattr(exc, 'strerror', None) or exc}", key=key) from None


def _same_file(a: Path, b: Path) -> bool:
    """True when both exist and are one file (a hard link counts)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _overlap(path: Path, inputs: Inputs, *, folder: bool, key: str | None) -> None:
    target = _resolve(path, key)
    for given in inputs.files:
        resolved = _resolve(given, None)
        if target == resolved or _same_file(path, given):
            raise InputError(path, f"is the input file {given}: an input is never "
                                   "overwritten; write elsewhere", key=key)
        if folder and resolved.is_relative_to(target):
            raise InputError(path, f"holds the input file {given}: write the output "
                                   "folder elsewhere", key=key)
    for given in inputs.folders:
        resolved = _resolve(given, None)
        if target.is_relative_to(resolved):
            raise InputError(path, f"is inside the input folder {given}, which is only "
                                   "read, never modified: write elsewhere", key=key)
        if folder and resolved.is_relative_to(target):
            raise InputError(path, f"holds the input folder {given}: write the output "
                                   "folder elsewhere", key=key)


def _ancestor_kind(path: Path, key: str | None) -> None:
    """The nearest existing ancestor of ``path`` must be a folder (a file there: no folder
    can be made below it)."""
    for parent in path.parents:
        try:
            if parent.exists() or parent.is_symlink():
                if not parent.is_dir():
                    raise InputError(path, f"cannot be written: {parent} is not a folder",
                                     key=key)
                return
        except (OSError, ValueError):
            return  # the writer names what is wrong


def check_file_output(path: str | Path, inputs: Inputs = Inputs(), *,
                      key: str | None = None) -> Path:
    """Refuse a file output that is an input, lies inside an input folder, is a directory,
    or lies below a file; return it as a Path.

    Raises
    ------
    InputError
        Naming the output (and ``key``, the option that gave it) and why.
    """
    path = Path(path)
    _overlap(path, inputs, folder=False, key=key)
    if path.is_dir():
        raise InputError(path, "is a directory, expected a file to write", key=key)
    _ancestor_kind(path, key)
    return path


def check_folder_output(path: str | Path, inputs: Inputs = Inputs(), *,
                        key: str | None = None) -> Path:
    """Refuse an output folder that is or lies inside an input folder, holds an input, is a
    regular file, or lies below one; return it as a Path.

    Raises
    ------
    InputError
        Naming the folder (and ``key``, the option that gave it) and why.
    """
    path = Path(path)
    _overlap(path, inputs, folder=True, key=key)
    if path.exists() and not path.is_dir():
        raise InputError(path, "is not a folder: expected a folder to write into", key=key)
    _ancestor_kind(path, key)
    return path


def check_files_in(folder: str | Path, names: Iterable[str], *, key: str | None = None) -> None:
    """Refuse when a file a command will write in ``folder`` exists as a directory (its
    rename would fail after all the work, next to the files renamed before it)."""
    for name in names:
        path = Path(folder) / name
        if path.is_dir() and not path.is_symlink():
            raise InputError(path, "is a directory, expected a file to write", key=key)


def check_fit_outputs(out_root: str | Path, reports: str | Path | None, tyre_id: str,
                      inputs: Inputs = Inputs()) -> None:
    """The outputs of one fit (``out_root/<id>/`` with its .tir, fit.json, CSV and
    extraction.json; ``reports/<id>.pdf`` unless ``reports`` is None), checked before the
    fit: none is an input or lies inside an input folder, none has the wrong kind.

    Raises
    ------
    InputError
        Naming the output, the option that gave it (``--out``, ``--reports``) and why.
    """
    fit_dir = check_folder_output(Path(out_root) / tyre_id, inputs, key="--out")
    check_files_in(fit_dir, (f"{tyre_id}.tir", JSON_NAME, CSV_NAME, EXTRACTION_NAME),
                   key="--out")
    mcmc = fit_dir / "mcmc"
    if mcmc.exists() and not mcmc.is_dir():
        raise InputError(mcmc, "is not a folder: the MCMC chains are written into it",
                         key="--out")
    if reports is not None:
        check_file_output(Path(reports) / f"{tyre_id}.pdf", inputs, key="--reports")
