"""A report as GitHub-flavoured Markdown: readable as plain text, rendered nicely on GitHub.

Figures become relative image links (the Markdown file lives in the run folder next to them),
tables become pipe tables with numeric columns right-aligned. Section text is passed through
unchanged: it is already Markdown-ish.
"""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import quote

from hmid.report._common import Cells, figure_file, relative_posix, section_text, table_cells, walk
from hmid.report.document import Report

_INLINE_SPECIAL = re.compile(r"([\\`*<|])")  # "_" and "[s]" stay: model names and units
_CODE_SPAN = re.compile(r"(`[^`\n]+`)")
_TAG_START = re.compile(r"<(?=[A-Za-z/!?])")


def _inline(text: str) -> str:
    """Plain text safe in a Markdown line or table cell (no markup, no line breaks)."""
    return _INLINE_SPECIAL.sub(r"\\\1", " ".join(text.split()))


def _alt(text: str) -> str:
    return _inline(text).replace("[", "\\[").replace("]", "\\]")


def _text(text: str) -> str:
    """Section text as written, except that "<tag" outside code spans is shown, not obeyed."""
    parts = _CODE_SPAN.split(section_text(text))
    return "".join(p if i % 2 else _TAG_START.sub(r"\\<", p) for i, p in enumerate(parts))


def _table(cells: Cells) -> list[str]:
    def row(items: tuple[str, ...] | list[str]) -> str:
        return "| " + " | ".join(items) + " |"

    header = [_inline(h) or " " for h in cells.header]
    rule = ["---:" if numeric else ":---" for numeric in cells.numeric]
    lines = [row(header), row(rule)]
    lines += [row([_inline(c) for c in r]) for r in cells.rows]
    return lines


def render_markdown(report: Report, run_dir: str | Path) -> str:
    """The report as Markdown for a file written directly inside ``run_dir``."""
    run_dir = Path(run_dir)
    out = [f"# {_inline(report.title)}", ""]
    if report.lead.strip():
        out += [_text(report.lead), ""]
    if report.summary:
        out += [f"- **{_inline(label)}:** {_inline(value)}" for label, value in report.summary]
        out.append("")
    n_tables = n_figures = 0
    for entry in walk(report):
        section = entry.section
        level = "#" * min(entry.depth + 1, 6)
        out += [f"{level} {entry.number}. {_inline(section.title)}", ""]
        text = _text(section.text)
        if text:
            out += [text, ""]
        for table in section.tables:
            n_tables += 1
            caption = f" {_inline(table.caption)}" if table.caption else ""
            out += [f"**Table {n_tables}.**{caption}", ""]
            out += _table(table_cells(table))
            out.append("")
        for figure in section.figures:
            n_figures += 1
            link = quote(relative_posix(figure_file(figure, run_dir), run_dir))
            alt = _alt(figure.caption) or f"Figure {n_figures}"
            caption = f" {_inline(figure.caption)}" if figure.caption else ""
            out += [f"![{alt}]({link})", "", f"*Figure {n_figures}.*{caption}", ""]
    if report.provenance:
        out += ["## Provenance", "", "| item | value |", "| :--- | :--- |"]
        out += [f"| {_inline(k)} | `{_code(v)}` |" for k, v in report.provenance.items()]
        out.append("")
    return "\n".join(out).rstrip("\n") + "\n"


def _code(text: str) -> str:
    """Text for an inline code span inside a table cell."""
    return " ".join(text.split()).replace("`", "'").replace("|", "\\|")


def markdown_table(frame, float_format: str | None = None) -> str:
    """A data frame as a pipe table, formatted as in reports."""
    from hmid.report.document import Table

    return "\n".join(_table(table_cells(Table(frame, "", float_format))))
