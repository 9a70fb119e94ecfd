"""A structural check of MATLAB v5 .mat bytes before :func:`scipy.io.loadmat` parses them.

scipy.io's v5 reader trusts what the file says: a data-type code it has no reader for indexes
a table of pointers out of range, a complex flag without an imaginary part or an element
longer than its container sends it reading elsewhere, and the process dies with a
segmentation fault (found by tests/unit/test_hostile_hypothesis.py with one or two bytes changed in
a TTC .mat file; scipy/scipy pull request 25349 describes the first). A file from a rig is
untrusted input, so the elements are walked here first, the way scipy's reader walks them;
anything it could not read safely is reported as a corrupt file, never handed to scipy. A file
cut short (an element running past the end of the file) is left to scipy, which raises its
own error for that.

Layout (MATLAB 5 MAT-file format): a 128-byte header whose bytes 126-127 are ``IM`` (little
endian) or ``MI`` (big endian), then variables: matrix elements (type 14), or compressed
elements (type 15: one zlib stream holding a matrix element). Each element has an 8-byte tag
(type, size in bytes) followed by its data padded to 8 bytes, or is a "small element": type
and size in the first 4 bytes (size in the upper half), data in the next 4. A matrix holds its
flags (class, complex), dimensions and name, then: the real (and imaginary) part for numeric,
char and logical classes; row indices, column starts and values for sparse; one matrix per
cell; the field names and one matrix per field and element for structs and objects.
"""
from __future__ import annotations

import struct
import zlib

from identify.io.isolated_parse import TIMEOUT, child_fate

__all__ = ["mat_problem", "loadmat_crash"]

#: Longest a child may take to parse a .mat file with scipy.io [s]: far beyond what a TTC
#: session takes, so that only a hung parser reaches it.
PARSE_SECONDS = 120.0

_CHILD = ("import io, sys, scipy.io; "
          "scipy.io.loadmat(io.BytesIO(sys.stdin.buffer.read()), simplify_cells=True)")

_MATRIX, _COMPRESSED = 14, 15
_NUMERIC = frozenset({1, 2, 3, 4, 5, 6, 7, 9, 12, 13})  # miINT8 .. miUINT64
_TEXT = _NUMERIC | {16, 17, 18}  # + miUTF8, miUTF16, miUTF32
_CELL, _STRUCT, _OBJECT, _CHAR, _SPARSE = 1, 2, 3, 4, 5
_DATA_CLASSES = frozenset(range(6, 16))  # double .. uint64
_COMPLEX = 0x800
#: Nesting depth at which a file is taken as corrupt (a TTC file is three levels deep).
_MAX_DEPTH = 32


class _Corrupt(Exception):
    pass


class _Truncated(Exception):
    """The file ends inside an element: scipy.io raises its own error for that."""


def mat_problem(data: bytes) -> str | None:
    """Why scipy.io must not parse ``data`` (the bytes of a MATLAB v5 file), or None.

    Parameters
    ----------
    data : bytes
        The whole file.

    Returns
    -------
    str or None
        A few words on the first element scipy could not read safely, with its byte offset;
        None otherwise (the content may still be unusable: scipy or the caller says so).
    """
    if len(data) < 128:
        return "shorter than the 128-byte MAT-file header"
    order = {b"IM": "<", b"MI": ">"}.get(data[126:128])
    if order is None:
        return "no MAT-file endian indicator (bytes 126-127)"
    try:
        _Walk(order).variables(data, 128)
    except _Corrupt as exc:
        return str(exc)
    except _Truncated:
        pass
    return None


class _Walk:
    def __init__(self, order: str) -> None:
        self.order = order
        self.file = b""

    def tag(self, buf: bytes, pos: int, end: int) -> tuple[int, int, int, int]:
        """(type, data start, data size, next position) of the element at ``pos`` inside
        ``buf[:end]``; running past the end of the file itself is a cut file (left to
        scipy), past the end of a container corruption."""
        cut = buf is self.file and end == len(buf)
        if end - pos < 8:
            if cut:
                raise _Truncated
            raise _Corrupt(f"an element tag cut at byte {pos}")
        first, second = struct.unpack_from(self.order + "II", buf, pos)
        if first >> 16:  # small element
            code, size = first & 0xFFFF, first >> 16
            if size > 4:
                raise _Corrupt(f"a small element of {size} bytes at byte {pos}")
            return code, pos + 4, size, pos + 8
        start = pos + 8
        if start + second > end:
            if cut:
                raise _Truncated
            raise _Corrupt(f"an element of {second} bytes at byte {pos} runs past its "
                           "container")
        pad = 0 if first == _COMPRESSED else -second % 8  # a zlib stream is not padded
        return first, start, second, min(start + second + pad, end)

    def variables(self, buf: bytes, pos: int) -> None:
        self.file = buf
        while pos < len(buf):
            if len(buf) - pos >= 8 and struct.unpack_from(self.order + "I", buf, pos)[0] \
                    == _MATRIX:  # a matrix cut by the end of the file: walk what is there
                size = struct.unpack_from(self.order + "I", buf, pos + 4)[0]
                if pos + 8 + size > len(buf):
                    self.matrix(buf, pos + 8, len(buf), 0)
                    raise _Truncated
            code, start, size, pos = self.tag(buf, pos, len(buf))
            if code == _COMPRESSED:
                try:
                    inner = zlib.decompress(buf[start:start + size])
                except zlib.error:
                    raise _Corrupt(f"a compressed element at byte {start - 8} does not "
                                   "decompress") from None
                icode, istart, isize, _ = self.tag(inner, 0, len(inner))
                if icode != _MATRIX:
                    raise _Corrupt(f"a compressed element at byte {start - 8} holds type "
                                   f"{icode}, not a matrix")
                self.matrix(inner, istart, istart + isize, 0)
            elif code == _MATRIX:
                self.matrix(buf, start, start + size, 0)
            else:
                raise _Corrupt(f"a variable of type {code} at byte {start - 8}, not a matrix")

    def element(self, buf: bytes, pos: int, end: int, allowed, what: str
                ) -> tuple[int, int, int, int]:
        code, start, size, nxt = self.tag(buf, pos, end)
        if code not in allowed:
            raise _Corrupt(f"{what} of type {code} at byte {pos}")
        return code, start, size, nxt

    def ints(self, buf: bytes, start: int, size: int, code: int) -> list[int]:
        if code not in (5, 6) or size % 4:
            raise _Corrupt(f"dimensions of type {code} and {size} bytes at byte {start}")
        return list(struct.unpack_from(f"{self.order}{size // 4}{'i' if code == 5 else 'I'}",
                                       buf, start))

    def matrix(self, buf: bytes, pos: int, end: int, depth: int) -> None:
        if pos == end:
            return  # an empty matrix
        if depth > _MAX_DEPTH:
            raise _Corrupt(f"matrices nested more than {_MAX_DEPTH} deep at byte {pos}")
        _, start, size, pos = self.element(buf, pos, end, {6}, "array flags")
        if size != 8:
            raise _Corrupt(f"array flags of {size} bytes at byte {start - 8}")
        flags = struct.unpack_from(self.order + "I", buf, start)[0]
        cls = flags & 0xFF
        code, start, size, pos = self.element(buf, pos, end, {5, 6}, "dimensions")
        dims = self.ints(buf, start, size, code)
        if len(dims) < 2 or min(dims) < 0:
            raise _Corrupt(f"dimensions {dims} at byte {start - 8}")
        count = 1
        for d in dims:
            count *= d
        _, _, _, pos = self.element(buf, pos, end, _NUMERIC, "array name")
        parts = 2 if flags & _COMPLEX else 1
        if cls in _DATA_CLASSES or cls == _CHAR:
            for _ in range(parts):
                _, _, _, pos = self.element(buf, pos, end, _TEXT if cls == _CHAR else _NUMERIC,
                                            "array data")
        elif cls == _SPARSE:
            for _ in range(2 + parts):
                _, _, _, pos = self.element(buf, pos, end, _NUMERIC, "sparse array data")
        elif cls in (_CELL, _STRUCT, _OBJECT):
            if cls == _OBJECT:
                _, _, _, pos = self.element(buf, pos, end, _NUMERIC, "class name")
            if cls != _CELL:
                code, start, size, pos = self.element(buf, pos, end, {5, 6}, "field name length")
                (length,) = self.ints(buf, start, 4, code) if size == 4 else (-1,)
                _, start, size, pos = self.element(buf, pos, end, _NUMERIC, "field names")
                if length <= 0 or size % length:
                    raise _Corrupt(f"field names of {size} bytes in fields of {length} at byte "
                                   f"{start - 8}")
                count *= size // length
            if count * 8 > end - pos:  # every cell or field is at least a tag
                raise _Corrupt(f"{count} cells or fields in {end - pos} bytes at byte {pos}")
            for _ in range(count):
                _, start, size, pos = self.element(buf, pos, end, {_MATRIX}, "a cell or field")
                self.matrix(buf, start, start + size, depth + 1)
        else:
            raise _Corrupt(f"array class {cls} at byte {pos}")


def loadmat_crash(data: bytes, timeout: float = PARSE_SECONDS) -> str | None:
    """Why scipy.io cannot parse the .mat bytes ``data`` without dying, or None.

    :func:`mat_problem` walks the elements the way scipy's reader does, but one hypothesis
    trial of 30,000 still crashed the process on a file it passed, with no Python frame on the
    stack. So the bytes are parsed once in a new interpreter (the cost of a scipy import;
    identify.io.isolated_parse); a child killed by a signal, or one that
    does not finish in ``timeout`` [s], is a corrupt file. An exception in the child is left to
    the caller's own parse, which reports it in its one line.
    """
    fate = child_fate(["-c", _CHILD], data, timeout)
    if fate == TIMEOUT:
        return f"scipy.io did not finish parsing it in {timeout:g} s"
    return None if fate is None else f"parsing it crashed scipy.io ({fate})"
