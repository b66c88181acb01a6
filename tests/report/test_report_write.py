"""write_report: both files written atomically, nothing left behind on success or failure."""

from __future__ import annotations

from pathlib import Path

import pytest

from hmid.report import Figure, Report, ReportError, Section, write_report


def test_writes_both_files_and_no_temporaries(tmp_path: Path, make_png) -> None:
    make_png(tmp_path / "fig.png")
    report = Report("R", sections=(Section("S", figures=(Figure(Path("fig.png"), "c"),)),))
    md, page = write_report(report, tmp_path)
    assert (md, page) == (tmp_path / "report.md", tmp_path / "report.html")
    assert md.read_text(encoding="utf-8").startswith("# R\n")
    assert page.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png", "report.html", "report.md"]
    write_report(Report("Again"), tmp_path)  # rewriting replaces in place
    assert md.read_text(encoding="utf-8").startswith("# Again\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png", "report.html", "report.md"]


def test_failure_writes_nothing(tmp_path: Path) -> None:
    report = Report("R", sections=(Section("S", figures=(Figure(Path("nope.png"), "c"),)),))
    with pytest.raises(ReportError, match=r"nope\.png"):
        write_report(report, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_decimated_trace_keeps_every_peak():
    """Figures draw ~4,000 points per panel; the min-max envelope keeps each bin's extremes,
    so a one-sample spike anywhere in a long series is still drawn."""
    import numpy as np

    from hmid.plots import envelope

    values = np.sin(np.linspace(0, 60, 200_000))
    values[123_457] = 9.0
    values[7] = -9.0
    keep = envelope(values, 4000)
    assert len(keep) <= 4000 and np.all(np.diff(keep) > 0)
    assert {7, 123_457} <= set(keep.tolist())
    assert values[keep].max() == 9.0 and values[keep].min() == -9.0
    np.testing.assert_array_equal(envelope(values[:100]), np.arange(100))
