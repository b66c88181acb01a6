"""Reports: a small document model and two renderers (Markdown and self-contained HTML).

Build a :class:`Report` from :class:`Section`, :class:`Table` and :class:`Figure` objects, then
:func:`write_report` writes ``report.md`` and ``report.html`` into the run folder. Rendering is a
pure function of the report and the figure files, so the same run gives byte-identical reports.
"""

from __future__ import annotations

from pathlib import Path

from hmid.files import write_text
from hmid.report._common import format_float
from hmid.report.document import Figure, Report, ReportError, Section, Table
from hmid.report.html import render_html
from hmid.report.markdown import render_markdown

__all__ = [
    "Figure",
    "Report",
    "ReportError",
    "Section",
    "Table",
    "format_float",
    "render_html",
    "render_markdown",
    "write_report",
]


def write_report(report: Report, run_dir: str | Path) -> tuple[Path, Path]:
    """Write ``report.md`` and ``report.html`` into ``run_dir``; returns their paths.

    Both are rendered before either is written, so a bad figure leaves no half-finished pair;
    each file is replaced atomically.
    """
    run_dir = Path(run_dir)
    markdown = render_markdown(report, run_dir)
    page = render_html(report, run_dir)
    return write_text(run_dir / "report.md", markdown), write_text(run_dir / "report.html", page)
