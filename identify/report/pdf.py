"""The PDF fit report, rebuilt from a fit directory alone (``mfid report FITDIR``).

Pages, in order: cover (tyre, provenance, settings, every fit with its total thesis error);
one page per fit (measured points and model lines, residuals, the thesis error per pressure
with the total first, the parameter table); the MF slip pages (Fy-alpha, Fx-kappa, Mz-alpha,
Mx-gamma, friction ellipse) when the fit has MF rows; the pressure prediction page (each
pressure level predicted by the MF stages fitted without it) when the fit has MF force stages;
MCMC pages when MCMC ran; the
data-quality page; the trailer pages; the vehicle pages when ``mfid fit --vehicle`` wrote
``vehicle/vehicle.json`` into the fit directory; an appendix of input files when the cover
cannot list them all.

matplotlib ``Figure`` objects (no pyplot state) go into ``PdfPages`` one per page and are
released after saving. matplotlib writes no document outline, so pypdf (a runtime dependency
for this) adds one bookmark per page, titled as the page, and opens the file with the outline
shown; pypdf writes the same bytes for the same input, and keeps the metadata. The file is
written to a temporary name in the target's folder and renamed, so an interrupted run leaves no
partial PDF. The metadata's CreationDate is the fit's creation time from fit.json, so the same
fit directory gives the same PDF. Given worker processes, one of them draws the cover and the
first fits' pages (about half the drawing) into a PDF of their own while this process draws
the rest; the two are then joined, in the same order, with the same titles and notes.
"""
from __future__ import annotations

import io
from concurrent.futures import Executor, wait
from dataclasses import dataclass
from pathlib import Path

from matplotlib.backends.backend_pdf import PdfPages
from pypdf import PdfReader, PdfWriter

from identify.core.atomic import atomic_path
from identify.core.errors import InputError
from identify.core.names import name_problem
from identify.core.progress import Progress
from identify.core.version import __version__
from identify.fit.run import JSON_NAME
from identify.io.fitdir import FitDir, read_fit_dir
from identify.report.cover import cover, inputs_appendix
from identify.report.every_sample_pages import every_sample_pages
from identify.report.fit_pages import fit_pages
from identify.report.mcmc_pages import mcmc_pages
from identify.report.pressure_pages import pressure_pages
from identify.report.quality_pages import quality_pages
from identify.report.slip_pages import mf_slip_pages, slip_pages
from identify.report.trailer_pages import trailer_pages
from identify.report.vehicle_pages import fit_vehicle_pages


@dataclass(frozen=True)
class Report:
    """A written report: its path and the title of every page, in order."""

    path: Path
    pages: tuple[str, ...]
    notes: tuple[str, ...]

    @property
    def n_pages(self) -> int:
        return len(self.pages)


def default_report_path(fd: FitDir, reports: str | Path = "reports") -> Path:
    """``reports/<tyre id>.pdf``; the id comes from fit.json, a file that may have been
    edited, so it is checked again here, where it becomes a path.

    Raises
    ------
    InputError
        The id is not a safe file name (``../../x`` would write outside ``reports``).
    """
    why = name_problem(fd.tyre_id)
    if why is not None:
        raise InputError(fd.path / JSON_NAME, why, key="tyre.id")
    return Path(reports) / f"{fd.tyre_id}.pdf"


def metadata(fd: FitDir) -> dict:
    """PDF metadata: Title, Author ("mfid <version>"), Subject, Keywords, CreationDate (the
    fit's creation time, for a reproducible file)."""
    relations = sorted({f.relation for f in fd.results})
    source = fd.tyre.source or "unknown"
    meta = {"Title": f"mfid fit report: {fd.tyre_id}",
            "Author": f"mfid {__version__}",
            "Subject": f"Magic Formula fit with inflation pressure of tyre {fd.tyre_id} "
                       f"({source} data)",
            "Keywords": "; ".join(["tyre model", "Magic Formula", "inflation pressure",
                                   fd.tyre_id] + relations),
            "Creator": f"mfid {__version__} (matplotlib)",
            "CreationDate": fd.provenance.created}
    if meta["CreationDate"] is None:
        del meta["CreationDate"]
    return meta


def _per_fit(fd: FitDir, fits, make, label: str, progress: Progress | None, notes: list[str]):
    """Yield the pages ``make(fd, fit)`` of every fit in turn; its note, if any, goes to
    ``notes``."""
    for fit in fits:
        if progress:
            progress(f"report: {label}{fit.relation} [{fit.form}]")
        pages, note = make(fd, fit)
        if note:
            notes.append(note)
        yield from pages


def build_pages(fd: FitDir, progress: Progress | None = None):
    """Yield (title, Figure) for every page, and collect notes in the generator's return."""
    notes = yield from _first_pages(fd, len(fd.results), progress)
    return (yield from _last_pages(fd, len(fd.results), progress, lambda: notes))


def _first_pages(fd: FitDir, split: int, progress: Progress | None = None):
    """The cover and the pages of the first ``split`` fits (:func:`build_pages`' first part);
    their notes in the generator's return."""
    notes: list[str] = []
    yield from cover(fd)
    yield from _per_fit(fd, fd.results[:split], fit_pages, "", progress, notes)
    return notes


def _last_pages(fd: FitDir, split: int, progress: Progress | None, earlier):
    """Every page after the first part's (:func:`build_pages`' second part): the pages of the
    fits from ``split`` on, then the rest. ``earlier()``: the notes of the first part, asked
    for when the data-quality page, which lists every note, is drawn; the report's notes (the
    first part's, then these) in the generator's return."""
    own: list[str] = []
    yield from _per_fit(fd, fd.results[split:], fit_pages, "", progress, own)
    slip, slip_notes = mf_slip_pages(fd)
    own += slip_notes
    if slip and progress:
        progress("report: MF slip pages")
    yield from slip_pages(fd, slip)
    yield from pressure_pages(fd)
    yield from every_sample_pages(fd)
    yield from _per_fit(fd, [f for f in fd.results if f.mcmc is not None], mcmc_pages, "MCMC ",
                        progress, own)
    notes = list(earlier()) + own
    yield from quality_pages(fd, notes)
    yield from trailer_pages(fd)
    yield from fit_vehicle_pages(fd)  # fits/<id>/vehicle/vehicle.json (mfid fit --vehicle)
    yield from inputs_appendix(fd)
    return notes


FIT_PAGE_POINTS = 3_000
"""What a fit's pages cost to draw beyond their points, in points (:func:`halves`)."""
LATER_PAGES_POINTS = 75_000
"""What the pages after the fits' cost to draw (slip pages: the model on its grids; trailer
pages: every sample), in points of a fit's pages (:func:`halves`)."""


def halves(fd: FitDir) -> int:
    """How many fits' pages go with the cover to the second process of
    :func:`_render_in_two`: the first fits whose drawing, counted as each fit's points plus
    FIT_PAGE_POINTS, comes nearest to half of all of it with the later pages'
    (LATER_PAGES_POINTS); the drawing of a fit's page grows with its points (every measured
    point is a marker), the rest with the session."""
    cost = [fit.n_points + FIT_PAGE_POINTS for fit in fd.results]
    half = (sum(cost) + LATER_PAGES_POINTS) / 2
    done, split = 0.0, 0
    for c in cost:
        if abs(done + c - half) > abs(done - half):
            break
        done, split = done + c, split + 1
    return split


def bookmark_titles(titles: list[str]) -> list[str]:
    """One bookmark title per page: the page title, numbered when several pages share it
    ("data flags (2)")."""
    seen: dict[str, int] = {}
    total = {t: titles.count(t) for t in titles}
    out = []
    for t in titles:
        seen[t] = seen.get(t, 0) + 1
        out.append(f"{t} ({seen[t]})" if total[t] > 1 else t)
    return out


def add_outline(path: str | Path, titles: list[str]) -> None:
    """Rewrite the PDF at ``path`` with one top-level bookmark per page (``titles`` in page
    order), the metadata kept and the outline shown on opening."""
    writer = PdfWriter(clone_from=PdfReader(io.BytesIO(Path(path).read_bytes())))
    for i, title in enumerate(bookmark_titles(titles)[:len(writer.pages)]):
        writer.add_outline_item(title=title, page_number=i)
    writer.page_mode = "/UseOutlines"
    with open(path, "wb") as f:
        writer.write(f)


def write_report(fit_dir: str | Path | FitDir, output: str | Path | None = None, *,
                 progress: Progress | None = None, pool: Executor | None = None) -> Report:
    """Write the PDF report of a fit directory.

    Parameters
    ----------
    fit_dir : path or FitDir
        ``fits/<tyre id>/`` as written by ``mfid fit``.
    output : path, optional
        The PDF (default ``reports/<tyre id>.pdf``); its folder is created.
    progress : callable, optional
        Called with a short text per stage.
    pool : Executor, optional
        Worker processes (identify.core.workers.process_pool): one of them draws the cover
        and the first fits' pages meanwhile (:func:`_render_in_two`; the same pages, titles
        and notes). None: every page here.

    Raises
    ------
    InputError
        The fit directory is missing or malformed, or the PDF cannot be written.
    """
    fd = fit_dir if isinstance(fit_dir, FitDir) else read_fit_dir(fit_dir)
    out = Path(output) if output is not None else default_report_path(fd)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out.parent, f"cannot create folder: {exc.strerror or exc}") from None
    with atomic_path(out) as tmp:
        if pool is not None:
            titles, notes = _render_in_two(fd, tmp, progress, pool)
        else:
            titles, notes = _render(fd, tmp, build_pages(fd, progress))
        add_outline(tmp, titles)
    return Report(out, tuple(titles), tuple(notes))


def _render(fd: FitDir, path: str | Path, pages) -> tuple[list[str], list[str]]:
    """Save the (title, Figure) pages of the generator ``pages`` to the PDF ``path``: their
    titles and the generator's notes."""
    titles: list[str] = []
    with PdfPages(path, metadata=metadata(fd)) as pdf:
        while True:
            try:
                title, fig = next(pages)
            except StopIteration as stop:
                notes = list(stop.value or [])
                break
            pdf.savefig(fig)
            fig.clear()  # release the page's artists (Figure objects: no pyplot registry)
            titles.append(title)
    return titles, notes


def _render_first(fd: FitDir, path: str, split: int) -> tuple[list[str], list[str]]:
    """The second process of :func:`_render_in_two`: the cover and the first ``split`` fits'
    pages to ``path``."""
    return _render(fd, path, _first_pages(fd, split))


def _render_in_two(fd: FitDir, path: str | Path, progress: Progress | None, pool: Executor
                   ) -> tuple[list[str], list[str]]:
    """:func:`_render` of every page, in two processes: the cover and the first fits' pages
    in a second process, the rest here (about half the drawing each: :func:`halves`), each
    to its own PDF; this one's pages are then appended to the second's. The pages, their
    order, titles and notes are those of the serial report."""
    first, split = Path(f"{path}.part1"), halves(fd)
    job = pool.submit(_render_first, fd, str(first), split)
    try:
        if progress:
            progress("report: the cover and the first fits' pages (drawn in a second process)")
        titles, notes = _render(fd, path, _last_pages(fd, split, progress,
                                                      lambda: job.result()[1]))
        first_titles = job.result()[0]
        writer = PdfWriter(clone_from=PdfReader(io.BytesIO(first.read_bytes())))
        writer.append(PdfReader(io.BytesIO(Path(path).read_bytes())))
        with open(path, "wb") as f:
            writer.write(f)
    finally:
        wait([job])  # the worker writes ``first``: it is never left behind
        first.unlink(missing_ok=True)
    return first_titles + titles, notes
