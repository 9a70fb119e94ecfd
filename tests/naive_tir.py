"""The simplest .tir reader a tool might have, to check that files mfid writes are readable by it.

Line based, as several open evaluators read: split the bytes at CRLF (a reader that cuts each
line at "newline minus 2" needs CRLF), skip blank lines, ``$``/``!`` comment lines and
``[SECTION]`` headers, cut a trailing ``$`` comment, then split at ``=``: a data line must hold
exactly one. Values are numbers or quoted strings.
"""
from __future__ import annotations

from pathlib import Path


def naive_read(path: str | Path) -> dict[str, dict[str, float | str]]:
    """section -> key -> value, or AssertionError naming the first line a naive reader fails on."""
    raw = Path(path).read_bytes()
    assert raw.endswith(b"\r\n"), f"{path}: does not end with CRLF"
    assert raw.count(b"\n") == raw.count(b"\r\n"), f"{path}: a line ends without CRLF"
    out: dict[str, dict[str, float | str]] = {}
    section = None
    tables = {"SHAPE", "DEFLECTION_LOAD_CURVE"}
    for n, line in enumerate(raw[:-2].split(b"\r\n"), start=1):
        text = line.decode("ascii")  # reference readers assume plain ASCII
        s = text.strip()
        if not s or s[0] in "$!":
            continue
        if s.startswith("["):
            section = s[1:s.index("]")]
            out.setdefault(section, {})
            continue
        if section in tables:
            continue
        parts = s.split("=")
        assert len(parts) == 2, f"{path}:{n}: {len(parts) - 1} '=' signs: {text!r}"
        key = parts[0].strip()
        value = parts[1].split("$")[0].strip()
        assert key and key.replace("_", "").isalnum(), f"{path}:{n}: bad key {key!r}"
        assert key not in out[section], f"{path}:{n}: {key} twice in [{section}]"
        out[section][key] = value.strip("'\"") if value[:1] in "'\"" else float(value)
    return out
