"""Read an HDF5 file's metadata in a forked child first: a corrupt file cannot hang or crash mfid.

The HDF5 library trusts a file's metadata. One corrupted byte in the heap entry of a
variable-length string attribute (a channel's ``units``) made it loop for good inside the C
library, found by tests/test_hostile_hypothesis.py; a Python timer cannot stop a loop that
never returns to Python. :func:`metadata_problem` therefore reads every group's and dataset's
attributes, names, shapes and types in a child process (``os.fork``: no new interpreter, the
parent's imports are shared) and waits at most :data:`PROBE_SECONDS`; a child that does not
finish, or dies of a signal, is a corrupt file. Exceptions in the child are left to the
parent's own reading, which turns them into its one-line errors. Without ``os.fork`` (Windows)
there is no probe.
"""
from __future__ import annotations

import hashlib
import os
import select
import signal
import time
from pathlib import Path

import h5py

__all__ = ["PROBE_SECONDS", "metadata_problem"]

#: How long reading a file's metadata may take [s] (a sound file of any size: milliseconds).
PROBE_SECONDS = 20.0


def _read_metadata(path: Path) -> list:
    seen = []
    with h5py.File(path, "r") as fh:
        objects = [fh]
        fh.visititems(lambda name, obj: objects.append(obj))
        for obj in objects:
            seen += [obj.attrs[key] for key in obj.attrs]
            if isinstance(obj, h5py.Dataset):
                seen += [obj.shape, obj.dtype]
    return seen


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
    if not hasattr(os, "fork"):
        return None
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: read, report through the pipe, never return into the caller
        code = 0
        try:
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's
            os.close(read)
            try:
                _read_metadata(Path(path))
            except BaseException:  # noqa: BLE001,S110 - the parent reads it and says why
                pass
            os.write(write, b"1")
        except BaseException:  # noqa: BLE001 - nothing may escape a forked child
            code = 1
        finally:
            os._exit(code)
    os.close(write)
    try:
        deadline = time.monotonic() + timeout
        done = b""
        while not done:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([read], [], [], left)[0]:
                os.kill(pid, signal.SIGKILL)
                return (f"reading its metadata did not finish in {timeout:g} s (the HDF5 "
                        "library loops on it)")
            done = os.read(read, 1) or b"eof"
        _, status = os.waitpid(pid, 0)
        pid = 0
        if os.WIFSIGNALED(status):
            return (f"reading its metadata crashed the HDF5 library "
                    f"({signal.Signals(os.WTERMSIG(status)).name})")
        return None
    finally:
        os.close(read)
        if pid:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(pid, 0)
