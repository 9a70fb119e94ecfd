"""Which folders of a batch need a fit: bad folders, duplicate tyre ids, outputs up to date.

A folder is **up to date** (skipped unless ``--force``) when all of these hold:

* its outputs exist: the .tir, fit.json, measured_vs_model.csv and, unless ``--no-report``,
  the report, which is not older than fit.json;
* fit.json was written by this mfid version with the same :class:`FitSettings` (seed, MCMC,
  ``--only``, FITTYP ...): fit.json records them, so "newer than the settings" is decidable;
* its input files are those fit.json lists (tyre.toml, every run file, an unlisted
  characteristics.csv), and every one still has the SHA-256 that fit.json recorded (a file
  touched but not changed does not refit; a file changed does, whatever its modification
  time: a copy that keeps the source's older time, ``cp -p``, ``rsync -a``, is still seen).

A second batch with nothing changed reads each folder's tyre.toml, fit.json and input files
(to hash them), and writes nothing.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from identify.core.errors import InputError
from identify.core.version import __version__
from identify.fit.run import CSV_NAME, JSON_NAME, FitRun, FitSettings
from identify.io.common import sha256_file
from identify.io.folder import IMPLICIT_TABLE
from identify.io.manifest import MANIFEST_NAME, Manifest, read_manifest

__all__ = ["Freshness", "folder_inputs", "freshness", "manifest_of", "recorded_inputs"]


@dataclass(frozen=True)
class Freshness:
    """Whether a folder's outputs are up to date, and why not; ``failed``: the fits the
    up-to-date fit.json lists as failed."""

    up_to_date: bool
    reason: str
    failed: tuple[str, ...] = ()


def manifest_of(folder: str | Path) -> tuple[Path, Manifest]:
    """The measurement folder (a folder, or its tyre.toml) and its validated manifest.

    Raises
    ------
    InputError
        Not a measurement folder, or its tyre.toml is malformed (the one-line message).
    """
    path = Path(folder)
    if path.name == MANIFEST_NAME and path.is_file():
        path = path.parent
    if not path.exists():
        raise InputError(path, "no such file or directory")
    if not path.is_dir():
        raise InputError(path, "mfid batch takes measurement folders (with tyre.toml); fit a "
                               "single characteristics table with mfid fit")
    manifest = read_manifest(path / MANIFEST_NAME)  # strict: raises on the first problem
    if manifest is None:
        raise InputError(path / MANIFEST_NAME, "cannot read the manifest")
    if not manifest.tyre.id:
        raise InputError(path / MANIFEST_NAME, "empty tyre id", key="tyre.id")
    return path, manifest


def folder_inputs(folder: Path, manifest: Manifest) -> set[str]:
    """The input files of a folder as ``load_folder`` checksums them (relative, POSIX)."""
    names = {MANIFEST_NAME} | {Path(r.file).as_posix() for r in manifest.runs}
    if (folder / IMPLICIT_TABLE).is_file():
        names.add(IMPLICIT_TABLE)
    return names


def recorded_inputs(run: FitRun) -> dict[str, str]:
    """fit.json's input files, relative to the folder they were read from -> SHA-256.

    fit.json records each path as the folder as given on the command line joined with the
    file's name; the tyre.toml entry gives that folder.
    """
    inputs = {i.path: i.sha256 for i in run.provenance.inputs}
    prefix = next((p[:-len(MANIFEST_NAME)] for p in inputs
                   if p == MANIFEST_NAME or p.endswith("/" + MANIFEST_NAME)), None)
    if prefix is None:
        return {}
    return {p[len(prefix):]: sha for p, sha in inputs.items() if p.startswith(prefix)}


def _mtime(path: Path) -> float | None:
    try:
        return path.stat().st_mtime
    except OSError:
        return None


def freshness(folder: Path, manifest: Manifest, fit_dir: Path, report: Path | None,
              settings: FitSettings) -> Freshness:
    """Whether ``fit_dir`` (and ``report``) are up to date for ``folder`` and ``settings``
    (the rules in the module docstring)."""
    fit_json = fit_dir / JSON_NAME
    stamp = _mtime(fit_json)
    if stamp is None:
        return Freshness(False, "not fitted yet")
    try:
        run = FitRun.from_dict(json.loads(fit_json.read_text(encoding="utf-8")))
    except (OSError, ValueError, InputError, TypeError):
        return Freshness(False, f"{fit_json} is unreadable")
    needed = [fit_dir / run.tir_name, fit_dir / CSV_NAME]
    missing = [p.name for p in needed if _mtime(p) is None]
    if missing:
        return Freshness(False, f"{', '.join(missing)} missing")
    if report is not None:
        made = _mtime(report)
        if made is None:
            return Freshness(False, "no report")
        if made < stamp:
            return Freshness(False, "report older than fit.json")
    if run.provenance.mfid_version != __version__:
        return Freshness(False, f"fitted by mfid {run.provenance.mfid_version or '?'}")
    if run.settings != settings:
        return Freshness(False, "settings changed")
    recorded = recorded_inputs(run)
    current = folder_inputs(folder, manifest)
    if set(recorded) != current:
        return Freshness(False, "input files added or removed")
    for name in sorted(current):
        try:
            sha = sha256_file(folder / name)
        except OSError:  # missing or unreadable: the fit says which, as mfid fit would
            return Freshness(False, f"{name} missing or unreadable")
        if sha != recorded[name]:
            return Freshness(False, f"{name} changed")
    return Freshness(True, "inputs (SHA-256), settings and version as recorded", tuple(run.failed))
