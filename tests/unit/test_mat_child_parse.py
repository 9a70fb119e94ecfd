"""The .mat bytes are parsed once in a child interpreter before scipy.io parses them in mfid.

The element walk of identify.io.ttc.mat_guard.mat_problem catches the crashes it knows; the child
parse catches the ones it does not (a hypothesis trial crashed the process on a file the walk
passed). Here the walk is bypassed on purpose, so that a file known to kill scipy.io shows what
the child reports.
"""
import struct

from identify.io.ttc.mat_guard import loadmat_crash, mat_problem
from tests.ttc_cases import small_mat


def test_a_sound_mat_file_parses_in_the_child(tmp_path):
    data = small_mat(tmp_path / "session.mat").read_bytes()
    assert loadmat_crash(data) is None


def test_a_file_that_kills_scipy_io_is_named_by_the_signal(tmp_path):
    data = bytearray(small_mat(tmp_path / "session.mat").read_bytes())
    at = data.find(struct.pack("<II", 9, 200 * 8))  # miDOUBLE, 200 samples: the ET vector
    data[at] = 200  # a type code scipy.io has no reader for: it indexes out of its table
    assert mat_problem(bytes(data)) is not None  # the walk alone already refuses it
    assert loadmat_crash(bytes(data)) == "parsing it crashed scipy.io (SIGSEGV)"


def test_a_parse_error_is_left_to_the_caller(tmp_path):
    data = small_mat(tmp_path / "session.mat").read_bytes()
    assert loadmat_crash(data[:300]) is None  # scipy raises (a cut file): not a crash
