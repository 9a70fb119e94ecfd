"""``simulate_folder``: write a complete simulated measurement folder, atomically.

Layout, manifest and channel names follow docs/measurement-folder.md. The folder is built in a
temporary directory next to ``outdir`` and renamed into place only when complete, so a failure
never leaves a partial folder.
"""
from __future__ import annotations

import dataclasses
import gzip
import json
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.atomic import replace_dir, temp_dir
from identify.core.errors import InputError
from identify.core.version import __version__
from identify.model.modes import FIT_MODE, TRAILER_MODE
from identify.model.parameters import defaults, spec
from identify.simulate.artefacts import Artefacts, add_noise, run_rng
from identify.simulate.coefficients import Relations, relations_from_tir
from identify.simulate.flatplank import locked_hub_runs, parking_runs, vertical_runs
from identify.simulate.flatplank_rolling import camber_runs, free_rolling_runs, relaxation_runs
from identify.simulate.grid import GRIDS, Grid
from identify.simulate.manifest import manifest_text
from identify.simulate.model import Run, TyreModel
from identify.simulate.rig import DEFAULT_RIG, Rig
from identify.simulate.trailer import trailer_runs
from identify.simulate.truth import characteristics

__all__ = ["SimulationResult", "simulate_folder", "split_hidden"]


@dataclass(frozen=True)
class SimulationResult:
    """What :func:`simulate_folder` wrote.

    Attributes
    ----------
    path : Path
        The folder.
    truth : dict
        The content of ``truth.json``.
    run_ids : tuple of str
        Every run of the manifest, in manifest order.
    contact : mapping of str to DataFrame
        Flatplank runs: the contact-patch Fx, Fy, Fz, Mx, My, Mz [N, N m] (ISO-W) and gamma
        [rad] the clean bridge channels encode (artefacts included, noise excluded).
    """

    path: Path
    truth: dict
    run_ids: tuple[str, ...]
    contact: Mapping[str, pd.DataFrame]


def split_hidden(hide: Mapping[str, float] | None, relations: Relations):
    """Split ``hide`` into .tir overrides and relation overrides (``"CFy.p2"``).

    Raises
    ------
    InputError
        For a name that is neither a numeric .tir key nor a relation coefficient.
    """
    tir: dict[str, float] = {}
    data_relations = relations
    for name, value in (hide or {}).items():
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise InputError(None, f"value {value!r} is not a number", key=name) from None
        if not np.isfinite(value):
            raise InputError(None, f"value {value!r} is not finite", key=name)
        if "." in name:
            try:
                data_relations = data_relations.with_value(name, value)
            except KeyError:
                raise InputError(None, "unknown relation coefficient (use e.g. CFy.p2, "
                                       "CMz.p1, CFz.qfz3)", key=name) from None
            continue
        try:
            is_string = spec(name.upper()).is_string
        except KeyError:
            raise InputError(None, "unknown .tir parameter", key=name) from None
        if is_string:
            raise InputError(None, "not a numeric .tir parameter", key=name)
        tir[name.upper()] = value
    return tir, data_relations


def _numeric_params(tir_params: Mapping[str, float]) -> dict[str, float]:
    full = {k: v for k, v in defaults().items() if not isinstance(v, str)}
    full.update({k: float(v) for k, v in tir_params.items() if not isinstance(v, str)})
    return full


def _prepare_target(outdir: Path, overwrite: bool) -> None:
    if outdir.exists() and not outdir.is_dir():
        raise InputError(outdir, "exists and is not a folder")
    if outdir.is_dir() and any(outdir.iterdir()) and not overwrite:
        raise InputError(outdir, "folder exists and is not empty (use overwrite)")


def _move_into_place(tmp: Path, outdir: Path, overwrite: bool) -> None:
    _prepare_target(outdir, overwrite)
    replace_dir(tmp, outdir)


def _csv_text(columns: Mapping[str, np.ndarray], digits: int | None) -> str:
    """The CSV text pandas' ``to_csv(index=False, lineterminator="\\n")`` writes for
    ``columns``, built with Python's float formatting (a few times faster for the thousands of
    small channel files of a folder). Shortest round-trip floats (``repr``, what pandas writes)
    by default, ``%.{digits}g`` with ``digits``. Columns pandas would write differently (not
    float64, a NaN cell, a name to quote) are written by pandas itself."""
    names = [str(name) for name in columns]
    arrays = [np.asarray(c) for c in columns.values()]
    plain = (all(a.dtype == np.float64 and a.ndim == 1 and a.size == arrays[0].size
                 and not np.isnan(a).any() for a in arrays)
             and not any(set(name) & set(',"\r\n') for name in names))
    fmt = None if not digits else f"%.{int(digits)}g"
    if not plain or not arrays:
        return pd.DataFrame(dict(columns)).to_csv(index=False, lineterminator="\n",
                                                  float_format=fmt)
    cell = repr if fmt is None else fmt.__mod__
    cells = [list(map(cell, a.tolist())) for a in arrays]
    return "\n".join([",".join(names), *map(",".join, zip(*cells))]) + "\n"


def _write_csv(path: Path, columns: Mapping[str, np.ndarray], digits: int | None) -> None:
    """Write a channel CSV; a name ending in ``.gz`` is gzip-compressed (no time stamp in the
    stream, so equal seeds still give byte-identical folders)."""
    # shortest round-trip floats by default: the loader's transform then recovers the
    # simulated contact-patch forces to round-off
    text = _csv_text(columns, digits)
    if path.suffix != ".gz":
        path.write_text(text, encoding="utf-8")
        return
    with open(path, "wb") as raw, gzip.GzipFile(filename="", mode="wb", fileobj=raw,
                                                mtime=0) as fh:
        fh.write(text.encode("utf-8"))


def simulate_folder(tir_params: Mapping[str, float], outdir: str | Path, *,
                    relations: Relations | None = None, seed: int = 0,
                    noise: float = 0.01, ar1_rho: float = 0.0, transients: bool = True,
                    stick_slip: bool = True, asymmetry: float = 0.0,
                    short_relaxation: bool = True, hide: Mapping[str, float] | None = None,
                    grid: str | Grid = "full", rig: Rig = DEFAULT_RIG, overwrite: bool = False,
                    tyre_id: str | None = None, digits: int | None = None,
                    compress: bool = False) -> SimulationResult:
    """Simulate every Flatplank and trailer test of a tyre and write a measurement folder.

    Parameters
    ----------
    tir_params : mapping
        Numeric .tir values in SI (``read_tir(path).params()``); missing keys take defaults.
    outdir : str or Path
        Folder to create (must be absent or empty unless ``overwrite``).
    relations : Relations, optional
        Flatplank structural relations (CFz, CFx, CFy, CMz, sidewall ring). Default: the
        relations the .tir carries (:func:`~identify.simulate.coefficients.relations_from_tir`:
        NOMPRES, the vertical and structural stiffness keys), so the data are that tyre's;
        hidden .tir keys (``hide``) enter the data's relations but not the recorded ones.
    seed : int
        Seed of the noise (``numpy.random.default_rng``); equal seeds give equal folders.
    noise : float
        Noise standard deviation as a fraction of each channel's RMS in its run [-].
    ar1_rho : float
        Lag-one correlation of the noise along each run [-].
    transients, stick_slip, short_relaxation : bool
        Start-up transients; stick-slip after saturation; relaxation runs of the
        longest-sigma cell too short for steady state.
    asymmetry : float
        Camber-induced forces at negative camber scaled by (1 + asymmetry) [-].
    hide : mapping, optional
        Effects the data contain but the recorded base model does not: .tir keys
        (``{"PPY5": -0.15}``) or relation coefficients (``{"CFy.p2": -0.05}``).
    grid : "full", "small" or Grid
        Test grid (``"small"`` for fast tests).
    rig : Rig
        Rig constants.
    overwrite : bool
        Replace a non-empty ``outdir``.
    tyre_id : str, optional
        Manifest tyre id (default: the folder name).
    digits : int, optional
        Significant digits of the channel files (default: shortest exact round trip).
    compress : bool
        Write the channel files gzip-compressed (``.csv.gz``; the loaders read either).

    Returns
    -------
    SimulationResult

    Raises
    ------
    InputError
        For a bad ``hide`` entry, a bad artefact setting or an occupied ``outdir``.
    """
    outdir = Path(outdir)
    if isinstance(grid, str) and grid not in GRIDS:
        raise InputError(None, f"unknown grid {grid!r} (one of {', '.join(GRIDS)})")
    grid = GRIDS[grid] if isinstance(grid, str) else grid
    if digits is not None and not 6 <= int(digits) <= 17:
        raise InputError(None, f"digits must lie in 6..17, not {digits!r}")
    try:
        art = Artefacts(seed=int(seed), noise=float(noise), ar1_rho=float(ar1_rho),
                        transients=bool(transients), stick_slip=bool(stick_slip),
                        asymmetry=float(asymmetry), short_relaxation=bool(short_relaxation))
    except ValueError as exc:
        raise InputError(None, str(exc)) from None
    base = _numeric_params(tir_params)
    recorded = relations if relations is not None else relations_from_tir(base)
    hidden_tir, _ = split_hidden(hide, recorded)
    # a hidden structural key (LATERAL_STIFFNESS, PFZ1, ...) changes the data's relations too
    data_base = recorded if relations is not None else relations_from_tir({**base, **hidden_tir})
    _, data_relations = split_hidden(hide, data_base)
    model = TyreModel({**base, **hidden_tir}, data_relations, rig)
    _prepare_target(outdir, overwrite)

    runs: list[Run] = [*vertical_runs(model, grid, art),
                       *locked_hub_runs(model, grid, art, "x"),
                       *locked_hub_runs(model, grid, art, "y"),
                       *parking_runs(model, grid, art), *relaxation_runs(model, grid, art),
                       *free_rolling_runs(model, grid, art), *camber_runs(model, grid, art),
                       *trailer_runs(model, grid)]
    if compress:
        runs = [dataclasses.replace(r, file=f"{r.file}.gz") for r in runs]
    truth_rows = characteristics(model, grid)
    eigen = [dict(r) for r in truth_rows if r["quantity"] == "f_nat"]
    rng = run_rng(art.seed, "characteristics.csv")
    for r in eigen:  # measured eigenfrequencies: a tenth of the channel noise level
        r["value"] = r["value"] * (1 + 0.1 * art.noise * rng.standard_normal())
    truth = {
        "generator": "identify.simulate", "mfid_version": __version__, "seed": art.seed,
        "artefacts": art.to_dict(), "grid": grid.to_dict(), "rig": rig.to_dict(),
        "model_modes": {"flatplank": FIT_MODE, "trailer": TRAILER_MODE},
        "fittyp": int(base["FITTYP"]), "tir": base,
        "hidden": {**hidden_tir, **{k: float(v) for k, v in (hide or {}).items() if "." in k}},
        "relations": recorded.to_dict(), "characteristics": truth_rows,
    }
    truth_text = json.dumps(truth, indent=1, allow_nan=False) + "\n"
    truth = json.loads(truth_text)  # the result holds exactly what the file holds
    tyre_id = tyre_id or outdir.name
    outdir.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_dir(outdir)
    try:
        (tmp / "flatplank").mkdir()
        (tmp / "trailer").mkdir()
        for run in runs:
            noisy = add_noise(run_rng(art.seed, run.run_id), run.channels, run.noisy, art.noise,
                              art.ar1_rho)
            _write_csv(tmp / run.file, noisy, digits)
        pd.DataFrame(eigen).to_csv(tmp / "characteristics.csv", index=False,
                                   lineterminator="\n")
        (tmp / "truth.json").write_text(truth_text, encoding="utf-8")
        (tmp / "tyre.toml").write_text(manifest_text(tyre_id, base, rig, runs), encoding="utf-8")
        _move_into_place(tmp, outdir, overwrite)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    contact = {r.run_id: pd.DataFrame(r.contact) for r in runs if r.contact is not None}
    return SimulationResult(outdir, truth, tuple(r.run_id for r in runs) + ("characteristics",),
                            contact)
