"""README.md and docs/*.md: every relative link and path reference resolves inside the repository.

A clone of the repository is all a user has: a link to a file that is not in it (``../shared``
beside a developer's checkout, a renamed page, a moved module) is a dead end. Checked:

* markdown links and images ``[text](target)``: the target exists inside the repository, and a
  ``#fragment`` names a heading of the target page (GitHub's heading anchors);
* path references in the text, code spans and code blocks that start with a top-level folder
  of the repository (``identify/...``, ``tests/...``, ``bench/...``, ``docs/...``,
  ``measurements/...``, ``.ci/...``): they exist (templates with ``<...>`` or ``*`` are skipped);
* anything starting with ``../``: it must resolve inside the repository.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

_FENCE = re.compile(r"^(```|~~~).*?^\1[ \t]*$", re.MULTILINE | re.DOTALL)
_LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$", re.MULTILINE)
_TOP = r"(?:identify|tests|bench|docs|measurements|\.ci)"
_PATH = re.compile(r"(?<![\w./-])(" + _TOP + r"/[^\s`'\"()\[\]<>*{},;|]*)")
_UP = re.compile(r"(?<![\w./-])((?:\.\./)+[^\s`'\"()\[\]<>*{},;|]*)")
_TEMPLATE = set("<>*{$")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, markup and punctuation dropped, blanks to -."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link keeps its text
    text = text.replace("`", "").strip().lower()
    text = "".join(ch for ch in text if ch.isalnum() or ch in " -_")
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """Every heading anchor of a markdown page (duplicates get -1, -2 ... as on GitHub)."""
    seen: dict[str, int] = {}
    out = set()
    for match in _HEADING.finditer(_FENCE.sub("", page.read_text(encoding="utf-8"))):
        base = slug(match.group(2))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def _inside(path: Path) -> bool:
    try:
        path.resolve().relative_to(ROOT)
    except ValueError:
        return False
    return True


def _name(path: Path) -> str:
    return str(path.relative_to(ROOT))


def link_problems(page: Path, text: str) -> list[str]:
    """Broken relative links of ``text`` (the content of ``page``)."""
    problems = []
    for match in _LINK.finditer(_FENCE.sub("", text)):
        target = match.group(1)
        if re.match(r"[a-z][a-z0-9+.-]*:", target, re.IGNORECASE):
            continue  # http:, https:, mailto: ...
        file_part, _, fragment = target.partition("#")
        dest = (page.parent / file_part) if file_part else page
        if not _inside(dest):
            problems.append(f"{_name(page)}: link leaves the repository: {target}")
        elif not dest.exists():
            problems.append(f"{_name(page)}: link to a missing file: {target}")
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            problems.append(f"{_name(page)}: no heading #{fragment} in {_name(dest.resolve())}")
    return problems


def _tokens(pattern: re.Pattern, text: str):
    for match in pattern.finditer(text):
        token = match.group(1).partition("#")[0].rstrip(".:")
        after = text[match.end():match.end() + 1]
        if token and after not in _TEMPLATE:
            yield token


def path_problems(page: Path, text: str) -> list[str]:
    """Path references of ``text`` that do not exist or leave the repository (markdown links
    are :func:`link_problems`'s)."""
    problems = []
    text = _LINK.sub(" ", text)
    for token in _tokens(_PATH, text):
        if not (ROOT / token).exists():
            problems.append(f"{_name(page)}: path not in the repository: {token}")
    for token in _tokens(_UP, text):
        dest = page.parent / token
        if not _inside(dest):
            problems.append(f"{_name(page)}: reference leaves the repository: {token}")
        elif not dest.exists():
            problems.append(f"{_name(page)}: path not in the repository: {token}")
    return problems


def test_the_pages_are_found():
    names = {p.name for p in PAGES}
    assert {"README.md", "model.md", "relations.md", "procedures.md", "discovery.md",
            "measurement-folder.md", "loaded-tables.md", "tir-files.md",
            "fit-directory.md"} <= names


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_links_resolve_inside_the_repository(page):
    assert link_problems(page, page.read_text(encoding="utf-8")) == []


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_path_references_resolve_inside_the_repository(page):
    assert path_problems(page, page.read_text(encoding="utf-8")) == []


def test_the_checks_find_what_they_look_for():
    page = ROOT / "docs" / "model.md"
    readme = ROOT / "README.md"
    text = ("[a](relations.md) [b](nope.md) [c](../../outside.md) [d](#no-such-heading) "
            "[e](relations.md#the-error-metric) [f](https://example.org/x.md) "
            "![g](missing.png)\n"
            "see `identify/model/evaluate.py`, identify/model/nothing.py, `../shared/spec/x.md`, "
            "`fits/<tyre id>/fit.json`, `tests/data/reference/golden/gold_<F>.csv`\n"
            "```\n[h](ignored-in-a-code-block.md)\n```\n")
    links = link_problems(page, text)
    assert links == ["docs/model.md: link to a missing file: nope.md",
                     "docs/model.md: link leaves the repository: ../../outside.md",
                     "docs/model.md: no heading #no-such-heading in docs/model.md",
                     "docs/model.md: link to a missing file: missing.png"]
    assert path_problems(page, text) == [
        "docs/model.md: path not in the repository: identify/model/nothing.py",
        "docs/model.md: path not in the repository: ../shared/spec/x.md"]
    assert path_problems(readme, text) == [
        "README.md: path not in the repository: identify/model/nothing.py",
        "README.md: reference leaves the repository: ../shared/spec/x.md"]


@pytest.mark.parametrize("heading,anchor", [
    ("10.1 Effective rolling radius Re and spin rate omega",
     "101-effective-rolling-radius-re-and-spin-rate-omega"),
    ("`fit.json`", "fitjson"),
    ("`[MFID_EXTENSIONS]`", "mfid_extensions"),
    ("Axes and signs (ISO-W, the same as TYDEX W)", "axes-and-signs-iso-w-the-same-as-tydex-w"),
    ("12. Where mfid's numbers depend on a choice", "12-where-mfids-numbers-depend-on-a-choice"),
])
def test_heading_anchors_follow_github(heading, anchor):
    assert slug(heading) == anchor
