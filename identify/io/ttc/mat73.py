"""MATLAB v7.3 ``.mat`` files (HDF5 inside): the part of the format a TTC session uses.

MATLAB saves with ``-v7.3`` (and must, for a variable over 2 GB) as an HDF5 file behind a
512-byte user block that starts like a v5 file (``MATLAB 7.3 MAT-file``, version 0x0200).
scipy.io cannot read it; h5py can, given MATLAB's conventions:

- every variable is a member of the root group, with the attribute ``MATLAB_class`` (``double``,
  ``single``, the integer classes, ``logical``, ``char``, ``cell``, ``struct``);
- arrays are stored transposed (MATLAB is column-major): an N x 1 column vector is an HDF5
  dataset of shape (1, N); a 1 x L ``char`` row is (L, 1) of uint16 character codes;
- a ``cell`` array is a dataset of object references to members of the group ``#refs#``;
- a scalar ``struct`` is a group whose members are its fields;
- an empty array is a dataset of its dimensions with the attribute ``MATLAB_empty`` = 1.

:func:`read_mat73` returns the variables as :func:`scipy.io.loadmat` with ``simplify_cells``
does for a v5 file (vectors as 1-D arrays, strings as str, a cell array as a list, a struct as
a dict), so that identify.io.ttc.files reads both versions alike. :func:`write_mat73` writes that
layout (the simulator's ``mat_version="7.3"``), so the reader is tested on files made to the
convention rather than on files of its own making only.

The file's metadata is read in a child process first (identify.io.hdf5.probe): a corrupt HDF5
file can make the library loop for good.
"""
from __future__ import annotations

from collections.abc import Container, Mapping
from pathlib import Path

import h5py
import numpy as np

from identify.io.hdf5.probe import HDF5_ERRORS, hdf5_error, metadata_problem

__all__ = ["Mat73Error", "is_mat73_header", "read_mat73", "write_mat73"]

#: The user block MATLAB puts before the HDF5 superblock [bytes].
USER_BLOCK = 512
_NUMERIC = {"double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
            "uint64", "logical"}
#: Variables MATLAB keeps for itself.
_INTERNAL = ("#refs#", "#subsystem#")


class Mat73Error(ValueError):
    """A v7.3 file that does not hold what its MATLAB attributes say (one line: why)."""


class Mat73Unread(Mat73Error):
    """A variable of a MATLAB class a TTC file does not hold (a function handle, an object)."""


def is_mat73_header(head: bytes) -> bool:
    """True when the first 128 bytes of a file are a MATLAB v7.3 header (version 0x0200)."""
    return head[:6] == b"MATLAB" and head[124:128] in (b"\x00\x02IM", b"\x02\x00MI")


def _class(obj) -> str:
    value = obj.attrs.get("MATLAB_class", b"")
    return (value.decode("ascii", "replace") if isinstance(value, bytes) else str(value))


def _name(key: str | bytes) -> str:
    """A member's name as text (h5py gives the bytes of a name that is not UTF-8)."""
    return key if isinstance(key, str) else key.decode("utf-8", "replace")


def _value(fh: h5py.File, obj, name: str, depth: int = 0):
    """One MATLAB variable (or field, or cell) as scipy.io's simplify_cells gives it."""
    if depth > 8:
        raise Mat73Error(f"{name}: nested deeper than a TTC file's variables")
    cls = _class(obj)
    if isinstance(obj, h5py.Group):
        if cls != "struct":
            raise Mat73Unread(f"{name}: a group of MATLAB class '{cls or 'none'}'")
        return {_name(k): _value(fh, obj[k], f"{name}.{_name(k)}", depth + 1) for k in obj}
    if int(np.asarray(obj.attrs.get("MATLAB_empty", 0)).reshape(-1)[0]) == 1:
        return "" if cls == "char" else np.zeros(0)
    data = obj[()]
    if cls == "char":
        codes = np.asarray(data, dtype=np.uint32).T.reshape(-1)
        return "".join(map(chr, codes))
    if cls == "cell":
        refs = np.asarray(data, dtype=object).T.reshape(-1)
        return [_value(fh, fh[r], f"{name}{{{i + 1}}}", depth + 1) for i, r in enumerate(refs)]
    if cls in _NUMERIC:
        array = np.asarray(data)
        if array.dtype.kind not in "fiub":  # complex numbers are a compound type
            raise Mat73Error(f"{name}: {cls} data of HDF5 type {array.dtype}")
        array = array.T.astype(bool) if cls == "logical" else array.T  # stored as uint8
        return array.reshape(-1) if array.ndim == 2 and 1 in array.shape else array
    raise Mat73Unread(f"{name}: MATLAB class '{cls or 'none'}' is not read")


def read_mat73(path: str | Path, needed: Container[str] = ()) -> dict:
    """The variables of the v7.3 file ``path``: name -> value (see module).

    A variable of a MATLAB class a TTC file does not hold (a function handle, an object) is
    left out, as scipy.io's reading of a v5 file leaves it to be skipped, unless its name is
    in ``needed``.

    Raises
    ------
    Mat73Error
        The file is corrupt, or a ``needed`` variable is of a kind a TTC file does not hold
        (one line).
    """
    path = Path(path)
    why = metadata_problem(path)
    if why is not None:
        raise Mat73Error(f"corrupt HDF5 inside ({why})")
    try:
        with h5py.File(path, "r") as fh:
            out = {}
            for key in fh:
                if key in _INTERNAL:
                    continue
                name = _name(key)
                try:
                    out[name] = _value(fh, fh[key], name)
                except Mat73Unread:
                    if name in needed:
                        raise
            return out
    except Mat73Error:
        raise
    except HDF5_ERRORS as exc:
        raise Mat73Error(f"corrupt HDF5 inside ({hdf5_error(exc)})") from None


def _char(group: h5py.Group, name: str, text: str) -> h5py.Dataset:
    """A 1 x L char row (an empty one as MATLAB writes it: its dimensions, MATLAB_empty)."""
    if text:
        ds = group.create_dataset(name, data=np.array([[ord(c)] for c in text], np.uint16))
        ds.attrs["MATLAB_int_decode"] = np.int32(2)
    else:
        ds = group.create_dataset(name, data=np.array([1, 0], np.uint64))
        ds.attrs["MATLAB_empty"] = np.uint8(1)
    ds.attrs["MATLAB_class"] = np.bytes_("char")
    return ds


def write_mat73(path: str | Path, columns: Mapping[str, np.ndarray],
                cells: Mapping[str, Mapping[str, list[str]]] | None = None,
                strings: Mapping[str, str] | None = None,
                header: str = "MATLAB 7.3 MAT-file, Platform: mfid, Created on: simulated") -> Path:
    """Write a v7.3 file: ``columns`` as N x 1 double vectors, ``cells`` as scalar structs of
    1 x n cell arrays of strings (``{"channel": {"name": [...], "units": [...]}}``), ``strings``
    as char rows; the 128-byte text header is ``header`` (fixed, so equal content gives equal
    files)."""
    path = Path(path)
    with h5py.File(path, "w", userblock_size=USER_BLOCK, libver="earliest") as fh:
        refs = fh.create_group("#refs#")
        for name, values in columns.items():
            ds = fh.create_dataset(name, data=np.asarray(values, float).reshape(1, -1))
            ds.attrs["MATLAB_class"] = np.bytes_("double")
        count = 0
        for name, fields in (cells or {}).items():
            grp = fh.create_group(name)
            grp.attrs["MATLAB_class"] = np.bytes_("struct")
            for field, texts in fields.items():
                targets = []
                for text in texts:
                    targets.append(_char(refs, f"c{count}", text).ref)
                    count += 1
                ds = grp.create_dataset(field, data=np.array([targets], dtype=h5py.ref_dtype).T,
                                        dtype=h5py.ref_dtype)
                ds.attrs["MATLAB_class"] = np.bytes_("cell")
        for name, text in (strings or {}).items():
            _char(fh, name, text)
    text = header.encode("ascii")[:116].ljust(116) + b"\x00" * 8 + b"\x00\x02IM"
    with open(path, "r+b") as fh:
        fh.write(text)
    return path
