"""Read an HDF5 file's metadata in a child process first: a corrupt file cannot hang or crash mfid.

The HDF5 library trusts a file's metadata. One changed byte in an HDF5 trailer file made it
loop for good inside the C library reading a channel's ``units`` attribute (found by
tests/unit/test_hostile_hypothesis.py); a Python timer cannot stop a loop that never returns to
Python. :func:`metadata_problem` therefore makes, in a child process, the reads that
identify.io.hdf5.channel_files makes: the groups, their attributes, each member's link and dataset,
its attributes by name and all of them, and the values of datasets up to :data:`SMALL_DATASET`
values; each read on its own, so that one that raises does not hide a later one that loops.
It waits at most :data:`PROBE_SECONDS`; a child that does not finish, or dies of a signal, is
a corrupt file. Exceptions in the child are left to the parent's own reading, which turns them
into its one-line errors.

The child is a new interpreter running this file (the cost of an h5py import; see
identify.io.isolated_parse for why not a fork).
"""
from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import h5py

from identify.io.isolated_parse import TIMEOUT, child_fate

__all__ = ["HDF5_ERRORS", "PROBE_SECONDS", "hdf5_error", "metadata_problem"]

#: How long reading a file's metadata may take [s] (a sound file of any size: milliseconds).
PROBE_SECONDS = 20.0


#: What h5py raises on a corrupt file once the probe passed it (corrupt metadata, a dangling
#: link or reference, a value of the wrong type): identify.io.hdf5.channel_files and
#: identify.io.ttc.mat73 turn
#: these into their one-line errors.
HDF5_ERRORS = (RuntimeError, KeyError, OSError, ValueError, TypeError, IndexError,
               AttributeError, OverflowError)


def hdf5_error(exc: BaseException) -> str:
    """One line for an exception of :data:`HDF5_ERRORS`: its type and first line."""
    text = str(exc)
    return f"{type(exc).__name__}: {text.splitlines()[0] if text else 'no detail'}"


#: Datasets up to this many values are read in the child as well (a larger one is read once,
#: by the parent).
SMALL_DATASET = 1_000_000


def _attempt(fn, *args):
    """``fn(*args)``, or None when it raises: every read is tried, whatever failed before."""
    try:
        return fn(*args)
    except Exception:  # noqa: BLE001 - the parent's reading reports it
        return None


def _read_dataset(ds) -> None:
    _attempt(lambda: (ds.ndim, ds.dtype, ds.size))
    for name in ("units", "long_name"):  # as the reader asks for them: by name
        _attempt(lambda n: ds.attrs[n] if n in ds.attrs else None, name)
    _attempt(lambda: [ds.attrs[k] for k in ds.attrs])
    if (_attempt(lambda: ds.size) or 0) <= SMALL_DATASET:
        _attempt(lambda: ds[()])


def _read_metadata(path: Path) -> None:
    """What :func:`identify.io.hdf5.channel_files.read_hdf5` reads, in its order, each read on its
    own."""
    with h5py.File(path, "r") as fh:
        members = _attempt(lambda: list(fh.values())) or []
        groups = [fh] + [v for v in members if isinstance(v, h5py.Group)]
        for grp in groups:
            _attempt(lambda g: dict(g.attrs.items()), grp)
            for key in _attempt(list, grp) or []:
                _attempt(lambda g, k: g.get(k, getlink=True), grp, key)
                ds = _attempt(lambda g, k: g.get(k), grp, key)
                if isinstance(ds, h5py.Dataset):
                    _read_dataset(ds)


#: The last file probed and its verdict: (path, size, mtime [ns], inode, digest of a file
#: under 1 MB) -> problem. A file read twice in a row (a check, then the load) is probed once.
_LAST: dict[tuple, str | None] = {}
_SMALL = 1 << 20


def metadata_problem(path: str | Path, timeout: float | None = None) -> str | None:
    """None when the metadata of the HDF5 file ``path`` can be read safely, else why not.

    Parameters
    ----------
    path : str or Path
        An HDF5 file (a regular file: the caller has checked).
    timeout : float, optional
        Longest wait for the child [s]; default :data:`PROBE_SECONDS`.
    """
    timeout = PROBE_SECONDS if timeout is None else timeout
    try:
        st = os.stat(path)
    except OSError:
        return None  # the reader says what is wrong with the path
    digest = ""
    if st.st_size < _SMALL:  # rewritten within one clock tick at the same size: its bytes
        try:
            digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        except OSError:
            return None
    key = (str(path), st.st_size, st.st_mtime_ns, st.st_ino, digest)
    if key not in _LAST:
        _LAST.clear()
        _LAST[key] = _probe(path, timeout)
    return _LAST[key]


def _probe(path: str | Path, timeout: float) -> str | None:
    fate = child_fate([__file__, os.fspath(path)], None, timeout)
    if fate == TIMEOUT:
        return (f"reading its metadata did not finish in {timeout:g} s (the HDF5 "
                "library loops on it)")
    return None if fate is None else f"reading its metadata crashed the HDF5 library ({fate})"


if __name__ == "__main__":  # the child: read; a crash or a loop is the parent's verdict
    try:
        _read_metadata(Path(sys.argv[1]))
    except Exception:  # noqa: BLE001,S110 - the parent reads the file itself and says why
        pass
