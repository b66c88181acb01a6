"""Markdown rendering: headings, summary, pipe tables, number formatting, image links."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hmid.report import Figure, Report, ReportError, Section, Table, format_float, render_markdown


@pytest.mark.parametrize(
    ("x", "text"),
    [
        (0.026123456, "0.02612"),
        (0.15, "0.1500"),
        (1.0, "1.000"),
        (9.99996, "10.00"),
        (-4123.456, "-4123"),
        (123456.7, "123457"),
        (1234567.0, "1.235e6"),
        (1.5e-5, "1.500e-5"),
        (0.0, "0"),
        (-0.0, "0"),
        (float("nan"), "NaN"),
        (float("-inf"), "-inf"),
    ],
)
def test_floats_get_four_significant_digits(x: float, text: str) -> None:
    assert format_float(x) == text


def _report(tmp_path: Path, make_png) -> Report:
    make_png(tmp_path / "figures" / "fit one.png")
    make_png(tmp_path / "figures" / "resid.png")
    metrics = pd.DataFrame(
        {
            "model": ["cubic_xvP", "linear | xvP"],
            "params": [10, 4],
            "RMSE [N]": [0.026123456789, 0.15139999],
            "AIC": [-4123.456, 1.5e-7],
            "n_logs": [6.0, np.nan],
            "converged": [True, False],
        }
    )
    fit = Figure(Path("figures/fit one.png"), "Measured vs predicted [held-out]")
    resid = Figure(tmp_path / "figures" / "resid.png", "Residuals")
    return Report(
        title="Identification report",
        summary=(("best model", "cubic_xvP"), ("held-out RMSE (one-step)", "0.026 N")),
        sections=(
            Section("Data", text="Six logs.\n\n- `P` saturates\n- gap in log 5"),
            Section(
                "Models",
                tables=(Table(metrics, "Held-out metrics"),),
                figures=(fit,),
                subsections=(Section("Residuals", figures=(resid,)),),
            ),
        ),
        provenance={"git commit": "3f2a9c1", "config hash": "sha256:ab12"},
    )


def test_markdown_layout(tmp_path: Path, make_png) -> None:
    md = render_markdown(_report(tmp_path, make_png), tmp_path)
    lines = md.splitlines()
    assert lines[0] == "# Identification report"
    assert "- **best model:** cubic_xvP" in lines
    assert (
        lines.index("## 1. Data") < lines.index("## 2. Models") < lines.index("### 2.1. Residuals")
    )
    assert "- `P` saturates" in lines  # section text passes through
    assert "| git commit | `3f2a9c1` |" in lines
    assert md.endswith("\n") and not md.endswith("\n\n")


def test_markdown_table(tmp_path: Path, make_png) -> None:
    lines = render_markdown(_report(tmp_path, make_png), tmp_path).splitlines()
    start = lines.index("**Table 1.** Held-out metrics") + 2
    table = lines[start : start + 4]
    assert table == [
        "| model | params | RMSE [N] | AIC | n_logs | converged |",
        "| :--- | ---: | ---: | ---: | ---: | :--- |",
        "| cubic_xvP | 10 | 0.02612 | -4123 | 6 | True |",
        r"| linear \| xvP | 4 | 0.15140 | 1.500e-7 | NaN | False |",
    ]


def test_markdown_images_are_relative_links(tmp_path: Path, make_png) -> None:
    lines = render_markdown(_report(tmp_path, make_png), tmp_path).splitlines()
    assert r"![Measured vs predicted \[held-out\]](figures/fit%20one.png)" in lines
    assert "![Residuals](figures/resid.png)" in lines  # absolute path made relative
    assert "*Figure 2.* Residuals" in lines
    assert str(tmp_path) not in "\n".join(lines)


def test_float_format_and_index(tmp_path: Path) -> None:
    frame = pd.DataFrame({"k": [1.23456, 2.0]}, index=pd.Index(["a", "b"], name="param"))
    report = Report("R", sections=(Section("S", tables=(Table(frame, "c", ".2f"),)),))
    lines = render_markdown(report, tmp_path).splitlines()
    assert "| param | k |" in lines and "| a | 1.23 |" in lines and "| b | 2.00 |" in lines


def test_markup_in_plain_text_is_escaped(tmp_path: Path) -> None:
    report = Report(
        "R <b>",
        summary=(("a|b", "**x**"),),
        sections=(Section("S", text="x < 3 and <script>alert(1)</script> but `<kept>`"),),
    )
    md = render_markdown(report, tmp_path)
    assert "# R \\<b>" in md and r"- **a\|b:** \*\*x\*\*" in md
    assert r"x < 3 and \<script>alert(1)\</script> but `<kept>`" in md


def test_figure_problems_are_loud(tmp_path: Path, make_png) -> None:
    def render(path: Path) -> str:
        report = Report("R", sections=(Section("S", figures=(Figure(path, "fit"),)),))
        return render_markdown(report, tmp_path / "run")

    with pytest.raises(ReportError, match=r"'fit'.*file not found"):
        render(Path("missing.png"))
    with pytest.raises(ReportError, match="not inside the run folder"):
        render(make_png(tmp_path / "elsewhere.png"))
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "fig.svg").write_text("<svg/>")
    with pytest.raises(ReportError, match="not a PNG"):
        render(Path("fig.svg"))


def test_the_lead_comes_before_the_summary_and_tables_keep_every_column(tmp_path) -> None:
    frame = pd.DataFrame({f"c{i}": [i] for i in range(9)})
    report = Report(
        "r",
        lead="**sls** wins",
        summary=(("rig", "demo"),),
        sections=(Section("s", tables=(Table(frame, "t", key_columns=("c0",)),)),),
    )
    text = render_markdown(report, tmp_path)
    assert text.index("**sls** wins") < text.index("- **rig:** demo")
    assert "| c0 | c1 | c2 | c3 | c4 | c5 | c6 | c7 | c8 |" in text
