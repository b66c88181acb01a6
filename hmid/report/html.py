"""A report as one self-contained HTML file: opens in any browser, offline, and prints cleanly.

Everything is inline: the stylesheet, the PNG figures (``data:`` URIs) and a small script that
records whether every image decoded (``<body data-images-ok="2/2">`` and a hidden
``<div id="img-check">``), so a headless browser can check the page. A Content-Security-Policy
allows only that stylesheet and script (by hash) and ``data:`` images: the page cannot load
anything from the network even if some text slipped through unescaped.

All text from the report is escaped with :func:`html.escape`. Section text supports a small,
safe subset of Markdown: paragraphs, ``**bold**``, ```code``` and ``"- "`` bullet lists.
"""

from __future__ import annotations

import base64
import hashlib
import html
import re
import struct
from dataclasses import replace
from pathlib import Path

from hmid.report._common import Cells, Entry, figure_file, section_text, table_cells, walk
from hmid.report.document import Figure, Report, Table

_CSS = """
:root { --ink: #1f2328; --muted: #59636e; --rule: #d1d9e0; --accent: #0969da;
  --box: #f3f8ff; --box-rule: #b6d3f5; --stripe: #f6f8fa; }
* { box-sizing: border-box; }
html { background: #eef1f4; }
body { margin: 0; padding: 2rem 1rem; color: var(--ink); line-height: 1.55;
  font: 16px/1.55 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial,
  sans-serif; }
main { max-width: 80rem; margin: 0 auto; background: #fff; padding: 2.5rem 3rem 2rem;
  border: 1px solid var(--rule); border-radius: 8px; box-shadow: 0 1px 3px rgb(0 0 0 / 6%); }
h1 { font-size: 1.9rem; line-height: 1.25; margin: 0 0 1.5rem; letter-spacing: -0.01em; }
h2 { font-size: 1.4rem; margin: 2.6rem 0 0.9rem; padding-bottom: 0.3rem;
  border-bottom: 1px solid var(--rule); }
h3 { font-size: 1.15rem; margin: 2rem 0 0.7rem; }
h4, h5, h6 { font-size: 1rem; margin: 1.6rem 0 0.6rem; }
.num { color: var(--muted); font-weight: 500; margin-right: 0.45em;
  font-variant-numeric: tabular-nums; }
p, ul { margin: 0 0 0.9rem; max-width: 60rem; }
ul { padding-left: 1.4rem; }
li { margin: 0.15rem 0; }
code { font: 0.88em/1.4 ui-monospace, "SF Mono", Menlo, Consolas, "DejaVu Sans Mono", monospace;
  background: #eff1f3; padding: 0.1em 0.35em; border-radius: 4px; overflow-wrap: anywhere; }
.summary { background: var(--box); border: 1px solid var(--box-rule);
  border-left: 5px solid var(--accent); border-radius: 6px; padding: 1.1rem 1.4rem 1.2rem; }
.summary h2 { font-size: 0.8rem; text-transform: uppercase; letter-spacing: 0.08em;
  color: var(--accent); border: 0; margin: 0 0 0.7rem; padding: 0; }
.summary dl { display: grid; grid-template-columns: repeat(auto-fit, minmax(13rem, 1fr));
  gap: 0.9rem 1.6rem; margin: 0; }
.summary dt { font-size: 0.8rem; color: var(--muted); text-transform: uppercase;
  letter-spacing: 0.04em; }
.summary dd { margin: 0.1rem 0 0; font-size: 1.05rem; font-weight: 600;
  font-variant-numeric: tabular-nums; overflow-wrap: anywhere; }
.summary .lead { margin: 0 0 1rem; }
.summary dl > div.long { grid-column: 1 / -1; }
.summary div.long dd { font-size: 0.95rem; font-weight: 500; }
.summary .lead p, .summary .lead ul { max-width: none; }
.summary .lead ul { columns: 2 24rem; column-gap: 2rem; }
nav.toc { margin: 1.6rem 0 0; font-size: 0.92rem; }
nav.toc h2 { font-size: 0.8rem; text-transform: uppercase; letter-spacing: 0.08em;
  color: var(--muted); border: 0; margin: 0 0 0.3rem; padding: 0; }
nav.toc ol { list-style: none; margin: 0; padding: 0; }
nav.toc > ol { columns: 2 22rem; column-gap: 2rem; }
nav.toc > ol > li { break-inside: avoid; }
nav.toc ol ol { padding-left: 1.4rem; }
nav.toc li { margin: 0.1rem 0; }
nav.toc a { color: var(--accent); text-decoration: none; }
nav.toc a:hover { text-decoration: underline; }
.table-wrap { overflow-x: auto; margin: 1.2rem 0 1.6rem; max-width: 100%; }
details { margin: 1rem 0 1.4rem; }
details > summary { cursor: pointer; font-size: 0.9rem; color: var(--muted); }
details > summary .more, details.all-columns > summary { color: var(--accent); }
details.all-columns { margin-top: -1rem; }
details.section > summary { list-style: none; }
details.section > summary > h3, details.section > summary > h4 { display: inline-block;
  margin: 0.8rem 0 0.4rem; }
details.section > summary::before { content: "▸ "; color: var(--accent); }
details.section[open] > summary::before { content: "▾ "; }
details > .table-wrap { margin-top: 0.6rem; }
table { border-collapse: collapse; font-size: 0.9rem; font-variant-numeric: tabular-nums; }
caption { caption-side: top; text-align: left; font-size: 0.9rem; color: var(--muted);
  padding-bottom: 0.45rem; }
th, td { padding: 0.38rem 0.8rem; text-align: left; vertical-align: top;
  border-bottom: 1px solid var(--rule); }
thead th { background: var(--stripe); border-bottom: 2px solid #afb8c1; font-weight: 600; }
tbody tr:nth-child(even) { background: #fbfcfd; }
th.r, td.r { text-align: right; }
td.r { white-space: nowrap; }
td { overflow-wrap: anywhere; }
.label { font-weight: 600; color: var(--ink); margin-right: 0.3em; }
figure { margin: 1.6rem 0 2rem; text-align: center; }
figure img { display: block; max-width: min(100%, 50rem); height: auto; margin: 0 auto; }
figcaption { font-size: 0.9rem; color: var(--muted); margin-top: 0.55rem; max-width: 46rem;
  margin-left: auto; margin-right: auto; }
footer.provenance { margin-top: 3rem; font-size: 0.85rem; color: var(--muted); }
footer.provenance h2 { font-size: 1rem; color: var(--ink); }
footer.provenance table { font-size: 0.85rem; width: 100%; }
footer.provenance th { width: 14rem; font-weight: 600; color: var(--ink); }
.img-warning { background: #fff1e5; border: 1px solid #d4a72c; padding: 0.6rem 1rem;
  border-radius: 6px; margin-bottom: 1rem; }
@media (max-width: 40rem) { body { padding: 0; } main { padding: 1.2rem; border: 0; } }
@media print {
  html, body { background: #fff; padding: 0; font-size: 11pt; }
  main { max-width: none; padding: 0; border: 0; box-shadow: none; }
  nav.toc { display: none; }
  .summary { print-color-adjust: exact; -webkit-print-color-adjust: exact; }
  figure, .summary, tr, caption { break-inside: avoid; }
  h2, h3, h4, caption { break-after: avoid; }
  thead { display: table-header-group; }
  .table-wrap { overflow: visible; }
  @page { margin: 16mm 14mm; }
}
"""

_SCRIPT = """
window.addEventListener("load", function () {
  var images = Array.prototype.slice.call(document.images);
  var ok = images.filter(function (im) { return im.complete && im.naturalWidth > 0; });
  var result = ok.length + "/" + images.length;
  document.body.dataset.imagesOk = result;
  var check = document.createElement("div");
  check.id = "img-check";
  check.hidden = true;
  check.textContent = "images decoded: " + result;
  document.body.appendChild(check);
  if (ok.length < images.length) {
    var warn = document.createElement("p");
    warn.className = "img-warning";
    warn.textContent = (images.length - ok.length) + " of " + images.length +
      " figures could not be displayed.";
    document.querySelector("main").prepend(warn);
  }
});
"""


#: A summary fact longer than this spans the box's width, in a lighter weight.
LONG_FACT = 48
_LONG = ' class="long"'


def _csp_hash(source: str) -> str:
    digest = hashlib.sha256(source.encode("utf-8")).digest()
    return "'sha256-" + base64.b64encode(digest).decode("ascii") + "'"


_CSP = (
    f"default-src 'none'; img-src data:; style-src {_csp_hash(_CSS)}; "
    f"script-src {_csp_hash(_SCRIPT)}; base-uri 'none'; form-action 'none'"
)

_e = html.escape
_CODE_SPAN = re.compile(r"(`[^`\n]+`)")
_BOLD = re.compile(r"\*\*(.+?)\*\*")


def _inline(text: str) -> str:
    """Escaped text with ``code`` spans and **bold**; markup inside code spans stays literal."""
    parts = []
    for i, part in enumerate(_CODE_SPAN.split(text)):
        if i % 2:
            parts.append(f"<code>{_e(part[1:-1])}</code>")
        else:
            parts.append(_BOLD.sub(r"<strong>\1</strong>", _e(part)))
    return "".join(parts)


def text_to_html(text: str) -> str:
    """Section text as HTML: blank-line paragraphs, "- " bullet lists, **bold**, `code`."""
    runs: list[tuple[str, list[str]]] = []  # ("p", lines) or ("ul", items), in order
    for block in re.split(r"\n\s*\n", section_text(text)):
        last = None
        for line in block.splitlines():
            stripped = line.strip()
            if not stripped:
                continue
            if stripped.startswith("- "):
                if last != "ul":
                    runs.append(("ul", []))
                runs[-1][1].append(stripped[2:].strip())
                last = "ul"
            elif last == "ul" and line[:1].isspace():  # indented continuation of a bullet
                runs[-1][1][-1] += " " + stripped
            else:
                if last != "p":
                    runs.append(("p", []))
                runs[-1][1].append(stripped)
                last = "p"
    html_blocks = []
    for kind, lines in runs:
        if kind == "p":
            html_blocks.append(f"<p>{_inline(' '.join(lines))}</p>")
        else:
            html_blocks.append("<ul>" + "".join(f"<li>{_inline(i)}</li>" for i in lines) + "</ul>")
    return "\n".join(html_blocks)


def _grid(table: Table, caption: str) -> str:
    cells: Cells = table_cells(table)

    def cls(j: int) -> str:
        return ' class="r"' if cells.numeric[j] else ""

    head = "".join(f'<th scope="col"{cls(j)}>{_e(h)}</th>' for j, h in enumerate(cells.header))
    body = "\n".join(
        "<tr>" + "".join(f"<td{cls(j)}>{_e(c)}</td>" for j, c in enumerate(row)) + "</tr>"
        for row in cells.rows
    )
    caption = f"<caption>{caption}</caption>\n" if caption else ""
    return (
        f'<div class="table-wrap"><table>\n{caption}'
        f"<thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody>\n</table></div>"
    )


def _table(table: Table, number: int) -> str:
    """A table: its key columns with the whole table behind a toggle, or all of it; a long one
    collapsed to its caption and one-line summary."""
    label = f'<span class="label">Table {number}.</span> {_e(table.caption)}'
    key = table.key_table()
    n_rows, n_columns = table.frame.shape
    if table.is_collapsed:
        summary = _e(table.summary) if table.summary else f"{n_rows} rows"
        inner = _grid(table, "") if key is None else (
            _grid(key, "") + _whole(table, n_columns))  # fmt: skip
        return (
            f'<details class="long"><summary>{label} <span class="more">{summary} '
            f"(show)</span></summary>\n{inner}\n</details>"
        )
    if key is None:
        return _grid(table, label)
    return _grid(key, label) + "\n" + _whole(table, n_columns)


def _whole(table: Table, n_columns: int) -> str:
    return (
        f'<details class="all-columns"><summary>all {n_columns} columns</summary>\n'
        f"{_grid(table, '')}\n</details>"
    )


def _figure(figure: Figure, number: int, run_dir: Path) -> str:
    data = figure_file(figure, run_dir).read_bytes()
    width, height = struct.unpack(">II", data[16:24])  # IHDR: the image size in pixels
    uri = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    alt = _e(figure.caption or f"Figure {number}")
    caption = f'<span class="label">Figure {number}.</span> {_e(figure.caption)}'
    shown = (
        f'<figure>\n<img src="{uri}" alt="{alt}" width="{width}" height="{height}">\n'
        f"<figcaption>{caption}</figcaption>\n</figure>"
    )
    if not figure.collapsed:
        return shown
    return (
        f'<details class="figure"><summary>{caption} <span class="more">(show)</span>'
        f"</summary>\n{shown}\n</details>"
    )


def render_html(report: Report, run_dir: str | Path) -> str:
    """The report as one self-contained HTML page; figures are read from ``run_dir``."""
    run_dir = Path(run_dir)
    entries = list(walk(report))
    out = _head(report.title)
    if report.summary:
        out += _summary(report)
    if len(entries) > 1:
        out.append(_toc(entries))
    n_tables = n_figures = 0
    closers: list[str] = []  # what closes each open section, deepest last
    for entry in entries:
        while len(closers) >= entry.depth:  # close finished sections, deepest first
            out.append(closers.pop())
        opening, closer = _opening(entry)
        out += opening
        closers.append(closer)
        section = entry.section
        if section.text.strip():
            out.append(text_to_html(section.text))
        for table in section.tables:
            n_tables += 1
            out.append(_table(table, n_tables))
        figures, n_figures = _figures(section.figures, n_figures, run_dir)
        out += figures
    out += reversed(closers)
    if report.provenance:
        out += _provenance(report.provenance)
    out += ["</main>", f"<script>{_SCRIPT}</script>", "</body>", "</html>"]
    return "\n".join(out) + "\n"


def _head(title: str) -> list[str]:
    """The page up to its title: the head (policy, styles) and the opening of the body."""
    return [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">',
        f"<title>{_e(title)}</title>",
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        "<main>",
        f"<header><h1>{_e(title)}</h1></header>",
    ]


def _summary(report: Report) -> list[str]:
    """The summary: the lead, then the key facts as a list (a long one takes a whole row)."""
    items = "\n".join(
        f"<div{_LONG if len(value) > LONG_FACT else ''}><dt>{_e(label)}</dt>"
        f"<dd>{_e(value)}</dd></div>"
        for label, value in report.summary
    )
    out = ['<section class="summary">', "<h2>Summary</h2>"]
    if report.lead.strip():
        out.append(f'<div class="lead">{text_to_html(report.lead)}</div>')
    out.append(f"<dl>\n{items}\n</dl>")
    out.append("</section>")
    return out


def _opening(entry: Entry) -> tuple[list[str], str]:
    """The lines that open a section, with its heading, and what closes it; a collapsed section
    opens from its heading."""
    section = entry.section
    level = min(entry.depth + 1, 6)
    out = [f'<section id="{_anchor(entry.number)}">']
    heading = f'<h{level}><span class="num">{entry.number}</span>{_e(section.title)}</h{level}>'
    if section.collapsed:  # the heading opens it
        more = f" {_e(section.summary)}" if section.summary else ""
        out.append(f'<details class="section"><summary>{heading}<span class="more">'
                   f"{more} (show)</span></summary>")  # fmt: skip
        return out, "</details></section>"
    out.append(heading)
    return out, "</section>"


def _figures(figures, n_figures: int, run_dir: Path) -> tuple[list[str], int]:
    """A section's figures numbered on from ``n_figures``, and the last number: those shown
    first, then those on request (several behind one line)."""
    out = []
    shown = [f for f in figures if not f.collapsed]
    for figure in shown:
        n_figures += 1
        out.append(_figure(figure, n_figures, run_dir))
    hidden = [f for f in figures if f.collapsed]
    if len(hidden) == 1:
        n_figures += 1
        out.append(_figure(hidden[0], n_figures, run_dir))
    elif hidden:  # several on request: one line opens them all
        first, n_figures = n_figures + 1, n_figures + len(hidden)
        inner = "\n".join(
            _figure(replace(f, collapsed=False), first + i, run_dir) for i, f in enumerate(hidden)
        )
        out.append(
            f'<details class="figure"><summary><span class="label">Figures {first}–'
            f"{n_figures}.</span> {_e('; '.join(f.caption for f in hidden))} "
            f'<span class="more">(show)</span></summary>\n{inner}\n</details>'
        )
    return out, n_figures


def _provenance(provenance) -> list[str]:
    """The footer: a one-line provenance that opens the whole table."""
    rows = "\n".join(
        f'<tr><th scope="row">{_e(k)}</th><td><code>{_e(v)}</code></td></tr>'
        for k, v in provenance.items()
    )
    return [
        '<footer class="provenance">',
        "<h2>Provenance</h2>",
        f"<details><summary>{_provenance_line(provenance)} (show all {len(provenance)})</summary>",
        f"<table>\n<tbody>\n{rows}\n</tbody>\n</table>",
        "</details>",
        "</footer>",
    ]


def _provenance_line(provenance) -> str:
    """The provenance's first entries in one line (config, commit, seed), for its toggle."""
    wanted = [k for k in ("config", "git commit", "seed") if k in provenance]
    shown = wanted or list(provenance)[:2]
    return _e("; ".join(f"{k}: {provenance[k]}" for k in shown))


def _anchor(number: str) -> str:
    return "sec-" + number.replace(".", "-")


def _toc(entries: list[Entry]) -> str:
    """The contents: every section but those collapsed (they open where they stand)."""
    hidden = [e.number for e in entries if e.section.collapsed]
    entries = [e for e in entries if not any(f"{e.number}.".startswith(f"{n}.") for n in hidden)]
    out = ['<nav class="toc" aria-label="Contents">', "<h2>Contents</h2>"]
    depth = 0
    for entry in entries:
        if entry.depth > depth:
            out.append("<ol>" * (entry.depth - depth))
        else:
            out.append("</li>" + "</ol></li>" * (depth - entry.depth))
        depth = entry.depth
        link = f'<a href="#{_anchor(entry.number)}">{entry.number} {_e(entry.section.title)}</a>'
        out.append(f"<li>{link}")
    out.append("</li>" + "</ol></li>" * (depth - 1) + "</ol>")
    out.append("</nav>")
    return "".join(out)
