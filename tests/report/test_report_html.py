"""HTML rendering: escaping, the small text markup, embedded figures, self-containedness."""

from __future__ import annotations

import base64
import re
from pathlib import Path

import pandas as pd

from hmid.report import Figure, Report, Section, Table, render_html
from hmid.report.html import text_to_html

EVIL = "<script>alert('x')</script>"


def _report(tmp_path: Path, make_png) -> Report:
    make_png(tmp_path / "figures" / "a.png", 40, 20)
    frame = pd.DataFrame({EVIL: [EVIL], "RMSE [N]": [0.0261234]})
    return Report(
        title=f"Report {EVIL}",
        summary=((f"best {EVIL}", f"model {EVIL}"),),
        sections=(
            Section(
                f"Section {EVIL}",
                text=f"Text {EVIL} & more",
                tables=(Table(frame, f"Table {EVIL}"),),
                figures=(Figure(Path("figures/a.png"), f"Caption {EVIL}"),),
                subsections=(Section("Sub"),),
            ),
        ),
        provenance={f"key {EVIL}": f"value {EVIL}", "remote": "https://example.org/hmid.git"},
    )


def test_all_text_is_escaped(tmp_path: Path, make_png) -> None:
    page = render_html(_report(tmp_path, make_png), tmp_path)
    assert "alert" in page
    assert "<script>alert" not in page
    assert page.count("<script>") == 1  # only the image check
    # title x2 (<title>, <h1>), summary x2, section x2 (heading, contents), text, table header,
    # cell, caption, figure alt and caption, provenance key and value (twice: in its table and
    # in the one line that opens it)
    assert page.count("&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;") == 16


def test_page_is_self_contained(tmp_path: Path, make_png, find_external) -> None:
    page = render_html(_report(tmp_path, make_png), tmp_path)
    assert find_external(page) == []
    csp = re.search(r'http-equiv="Content-Security-Policy" content="([^"]+)"', page)
    assert csp and "default-src 'none'" in csp.group(1) and "img-src data:" in csp.group(1)
    assert "https://example.org/hmid.git" in page  # shown as text, not as a link


def test_static_check_catches_external_references(find_external) -> None:
    leaky = [
        '<img src="http://example.org/a.png">',
        "<img src='//cdn.example.org/a.png'>",
        '<a href="https://example.org">x</a>',
        '<link rel="stylesheet" href="style.css">',
        "<script src=app.js></script>",
        "<style>@import 'x.css';</style>",
        '<div style="background: url(x.png)"></div>',
    ]
    for html in leaky:
        assert find_external(html), html


def test_figures_are_embedded_as_png_data(tmp_path: Path, make_png) -> None:
    page = render_html(_report(tmp_path, make_png), tmp_path)
    (src,) = re.findall(r'<img src="data:image/png;base64,([^"]+)"', page)
    assert base64.b64decode(src) == (tmp_path / "figures" / "a.png").read_bytes()
    assert 'width="40" height="20"' in page
    assert "Figure 1.</span> Caption &lt;script&gt;" in page


def test_structure_and_determinism(tmp_path: Path, make_png) -> None:
    report = _report(tmp_path, make_png)
    page = render_html(report, tmp_path)
    assert page == render_html(report, tmp_path)
    assert page.startswith("<!DOCTYPE html>") and page.endswith("</html>\n")
    assert page.count("<section") == page.count("</section>") == 3  # summary, 1, 1.1
    assert page.index('class="summary"') < page.index('id="sec-1"') < page.index("Provenance")
    assert '<a href="#sec-1-1">1.1 Sub</a>' in page
    assert '<td class="r">0.02612</td>' in page  # numeric cells right-aligned


def test_text_markup() -> None:
    text = """
        First **bold** and `code **not bold**`
        continues here.

        Flags:
        - one `x<y`
        - two
          continued
        After the list.
    """
    assert text_to_html(text) == "\n".join(
        [
            "<p>First <strong>bold</strong> and <code>code **not bold**</code> continues here.</p>",
            "<p>Flags:</p>",
            "<ul><li>one <code>x&lt;y</code></li><li>two continued</li></ul>",
            "<p>After the list.</p>",
        ]
    )
    assert text_to_html("") == ""
    assert text_to_html("**<i>x</i>**") == "<p><strong>&lt;i&gt;x&lt;/i&gt;</strong></p>"


def _wide(rows: int = 3) -> pd.DataFrame:
    return pd.DataFrame({f"column {i}": [0.5 * i] * rows for i in range(12)})


def test_key_columns_first_the_whole_table_behind_a_toggle(tmp_path: Path) -> None:
    table = Table(_wide(), "Wide", key_columns=("column 0", "column 3"))
    page = render_html(Report("r", sections=(Section("s", tables=(table,)),)), tmp_path)
    shown, hidden = page.split('<details class="all-columns">')
    assert "column 3" in shown and "column 4" not in shown
    assert "all 12 columns" in hidden and "column 11" in hidden
    assert page.count("Table 1.") == 1


def test_a_long_table_is_collapsed_to_its_summary(tmp_path: Path) -> None:
    long = Table(_wide(40), "Long", summary="40 rows of twelve")
    short = Table(_wide(3), "Short")
    page = render_html(Report("r", sections=(Section("s", tables=(long, short)),)), tmp_path)
    assert '<details class="long"><summary><span class="label">Table 1.</span> Long' in page
    assert "40 rows of twelve (show)" in page
    assert page.count("<details") == 1  # the short table is shown as it is


def test_key_columns_must_be_columns() -> None:
    import pytest

    with pytest.raises(ValueError, match=r"\['nope'\] are not columns"):
        Table(_wide(), "Wide", key_columns=("nope",))


def test_the_lead_opens_the_summary(tmp_path: Path) -> None:
    report = Report("r", lead="**sls** wins\n\n- k = 1 N/m", summary=(("rig", "demo"),))
    page = render_html(report, tmp_path)
    summary = page[page.index('<section class="summary">') :]
    assert summary.index('<div class="lead"><p><strong>sls</strong> wins</p>') < summary.index(
        "<dl>"
    )
    assert "<li>k = 1 N/m</li>" in summary
