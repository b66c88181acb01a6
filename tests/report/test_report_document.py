"""The document model: construction checks, normalisation, immutability."""

from __future__ import annotations

from dataclasses import FrozenInstanceError
from pathlib import Path

import pandas as pd
import pytest

from hmid.report import Figure, Report, Section, Table


def test_lists_become_tuples_and_paths_become_path() -> None:
    figure = Figure("figures/a.png", "caption")  # type: ignore[arg-type]
    table = Table(pd.DataFrame({"a": [1]}), "t")
    section = Section("S", tables=[table], figures=[figure])  # type: ignore[arg-type]
    report = Report("R", summary=[("k", "v")], sections=[section])  # type: ignore[arg-type]
    assert figure.path == Path("figures/a.png")
    assert section.tables == (table,) and section.figures == (figure,)
    assert report.summary == (("k", "v"),) and report.sections == (section,)


def test_report_is_immutable_and_detached_from_caller_data() -> None:
    frame = pd.DataFrame({"rmse": [0.1, 0.2]})
    provenance = {"git commit": "abc123"}
    table = Table(frame, "metrics")
    report = Report("R", sections=(Section("S", tables=(table,)),), provenance=provenance)
    frame.loc[0, "rmse"] = 99.0
    provenance["git commit"] = "changed"
    assert table.frame.loc[0, "rmse"] == 0.1
    assert report.provenance["git commit"] == "abc123"
    with pytest.raises(TypeError):
        report.provenance["x"] = "y"  # type: ignore[index]
    with pytest.raises(FrozenInstanceError):
        report.title = "other"  # type: ignore[misc]


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: Report(""), "Report.title must not be empty"),
        (lambda: Report("R", summary=(("only one",),)), r"Report.summary\[0\]"),
        (lambda: Report("R", summary=(("k", 0.026),)), r"Report.summary\[0\]"),
        (lambda: Report("R", sections=("not a section",)), r"Report.sections\[0\]"),
        (lambda: Report("R", sections="S"), "Report.sections must be a tuple"),
        (lambda: Report("R", provenance={"seed": 3}), "provenance entry 'seed'"),
        (lambda: Report("R", provenance=[("a", "b")]), "provenance must be a mapping"),
        (lambda: Section("  "), "Section.title must not be empty"),
        (lambda: Section("S", text=None), "Section.text must be a str"),
        (lambda: Section("S", figures=(Path("a.png"),)), r"Section.figures\[0\]"),
        (lambda: Table([[1, 2]], "t"), "Table.frame must be a pandas DataFrame"),
        (lambda: Table(pd.DataFrame(), "t", float_format=".3q"), "not a float format spec"),
        (lambda: Figure(3, "c"), "Figure.path must be a Path"),
    ],
)
def test_bad_values_are_rejected_at_construction(build, message: str) -> None:
    with pytest.raises((TypeError, ValueError), match=message):
        build()
