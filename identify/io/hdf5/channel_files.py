"""HDF5 channel files (docs/measurement-folder.md): one group per run, one 1-D dataset per channel.

Each dataset has the attributes ``units`` and ``long_name``; the time channel is a dimension
scale attached to every other dataset of its group. Read with h5py (pandas' ``read_hdf`` only
reads files pandas wrote). Writing goes to a temporary file that is renamed into place.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import h5py
import numpy as np

from identify.core.atomic import atomic_path
from identify.io.common import Problems, starts_with
from identify.io.hdf5.probe import HDF5_ERRORS, hdf5_error, metadata_problem

__all__ = ["HDF5_SIGNATURE", "RawRun", "is_hdf5", "read_hdf5", "write_hdf5"]

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


@dataclass(frozen=True, eq=False)
class RawRun:
    """The channels of one run as stored: values, unit strings, long names, group attributes."""

    name: str
    data: Mapping[str, np.ndarray]
    units: Mapping[str, str] = field(default_factory=dict)
    long_names: Mapping[str, str] = field(default_factory=dict)
    attrs: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("data", "units", "long_names", "attrs"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))


def is_hdf5(path: str | Path) -> bool:
    """True when the file starts with the HDF5 signature."""
    return starts_with(path, HDF5_SIGNATURE)


def _text(value) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.size == 1:
        return _text(value.reshape(-1)[0])
    return str(value)


def read_hdf5(path: str | Path, problems: Problems, *, run: str | None = None,
              time: str = "RUNTIME", allow_nan: bool = False) -> list[RawRun] | None:
    """Read the runs (groups) of an HDF5 channel file; ``run`` selects one group.

    With ``allow_nan`` NaN/inf values are read as NaN instead of being reported (trailer data:
    the loader cleans them and warns).

    A group named ``run`` is taken; if there is none and the file has exactly one group, that
    one is. Datasets at the file's root count as one run named after the file.
    """

    path = Path(path)
    start = problems.total
    why = metadata_problem(path)  # in a child: a corrupt file can make HDF5 loop for good
    if why is not None:
        problems.add(path, f"corrupt HDF5 file ({why})")
        return None
    try:
        fh = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        problems.add(path, f"cannot read HDF5 file: {str(exc).splitlines()[0]}")
        return None
    try:
        with fh:
            return _runs(path, fh, problems, run, time, allow_nan, start)
    except HDF5_ERRORS as exc:  # corrupt metadata, a dangling link
        problems.add(path, f"corrupt HDF5 file ({hdf5_error(exc)})")
        return None


def _runs(path: Path, fh, problems: Problems, run: str | None, time: str, allow_nan: bool,
          start: int) -> list[RawRun] | None:
    groups = {k: v for k, v in fh.items() if isinstance(v, h5py.Group)}
    if not groups and any(isinstance(v, h5py.Dataset) for v in fh.values()):
        groups = {path.stem: fh}
    if not groups:
        problems.add(path, "no run groups (and no datasets) in the HDF5 file")
        return None
    if run is not None:
        if run in groups:
            groups = {run: groups[run]}
        elif len(groups) == 1:
            groups = {run: next(iter(groups.values()))}
        else:
            problems.add(path, f"no group '{run}' (groups: {', '.join(groups)})", key=run)
            return None
    runs = [_group(path, name, grp, problems, time, allow_nan) for name, grp in groups.items()]
    return None if problems.total > start else runs


def _group(path: Path, name: str, grp, problems: Problems, time: str,
           allow_nan: bool = False) -> RawRun | None:

    data, units, long_names = {}, {}, {}
    for key in grp:
        link = grp.get(key, getlink=True)
        try:
            ds = grp.get(key)
        except (KeyError, OSError, RuntimeError):  # an external link to a missing file
            ds = None
        if ds is None and isinstance(link, (h5py.SoftLink, h5py.ExternalLink)):
            problems.add(path, f"dangling link to {getattr(link, 'path', '?')}",
                         key=f"{name}/{key}")
            continue
        if not isinstance(ds, h5py.Dataset):
            continue
        if ds.ndim != 1 or ds.dtype.kind not in "fiu":
            problems.add(path, f"expected a 1-D numeric dataset, got shape {ds.shape} of "
                               f"{ds.dtype}", key=f"{name}/{key}")
            continue
        values = ds[()].astype(np.float64)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size and allow_nan:
            values[bad] = np.nan
        elif bad.size:
            problems.add(path, f"{bad.size} NaN/inf value(s), first at sample {bad[0]}",
                         key=f"{name}/{key}")
        data[key] = values
        if "units" in ds.attrs:
            units[key] = _text(ds.attrs["units"])
        if "long_name" in ds.attrs:
            long_names[key] = _text(ds.attrs["long_name"])
    lengths = {k: v.size for k, v in data.items()}
    ref = lengths.get(time, max(lengths.values(), default=0))
    if data and ref == 0:
        problems.add(path, "0 samples: the group's datasets are empty", key=name)
    for key, n in lengths.items():
        if n != ref:
            problems.add(path, f"{n} samples, but {time} has {ref}", key=f"{name}/{key}")
    if not data:
        problems.add(path, "group has no datasets", key=name)
    attrs = {k: _text(v) for k, v in grp.attrs.items()}
    return RawRun(name, data, units, long_names, attrs)


def write_hdf5(path: str | Path, runs: Sequence[RawRun], *, time: str = "RUNTIME") -> Path:
    """Write runs to an HDF5 file atomically (the file is replaced as a whole).

    The ``time`` channel of each group is made a dimension scale and attached to every other
    dataset of the group.
    """

    target = Path(path)
    with atomic_path(target) as tmp:
        with h5py.File(tmp, "w", track_order=True) as fh:
            for run in runs:
                grp = fh.create_group(run.name, track_order=True)
                for key, value in run.attrs.items():
                    grp.attrs[key] = value
                for key, values in run.data.items():
                    ds = grp.create_dataset(key, data=np.asarray(values, dtype=np.float64))
                    ds.attrs["units"] = run.units.get(key, "")
                    ds.attrs["long_name"] = run.long_names.get(key, key)
                if time in grp:
                    grp[time].make_scale(time)
                    for key in grp:
                        if key != time:
                            grp[key].dims[0].attach_scale(grp[time])
    return target
