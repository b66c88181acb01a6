"""The report document model: a title, key facts, nested sections, and provenance.

A :class:`Report` is plain immutable data; it knows nothing about Markdown or HTML. Stages build
one from their results and hand it to :func:`hmid.report.write_report`, which renders it.

Construction checks types and values, so a bad report fails where it is built rather than in a
renderer. Sequences given as lists are stored as tuples, ``provenance`` as a read-only mapping,
and a table's frame as a private copy, so later changes by the caller cannot alter the report.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import pandas as pd

from hmid.errors import HmidError


class ReportError(HmidError, ValueError):
    """A report cannot be rendered as given (missing or non-PNG figure, figure outside the run)."""


def _set(obj: object, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)  # normalising fields of a frozen dataclass


def _check_str(owner: str, name: str, value: object, *, nonempty: bool = False) -> None:
    if not isinstance(value, str):
        raise TypeError(f"{owner}.{name} must be a str, got {type(value).__name__}")
    if nonempty and not value.strip():
        raise ValueError(f"{owner}.{name} must not be empty")


def _as_tuple(owner: str, name: str, value: object, kind: type) -> tuple:
    if isinstance(value, str | bytes) or not hasattr(value, "__iter__"):
        raise TypeError(f"{owner}.{name} must be a tuple of {kind.__name__}, got {value!r}")
    items = tuple(value)
    for i, item in enumerate(items):
        if not isinstance(item, kind):
            raise TypeError(
                f"{owner}.{name}[{i}] must be a {kind.__name__}, got {type(item).__name__}"
            )
    return items


@dataclass(frozen=True)
class Figure:
    """A PNG image already written inside the run folder, with its caption.

    ``path`` may be absolute or relative to the run folder; renderers check that the file exists,
    is a PNG and lies inside the run folder, so the report stays valid when the folder is moved.
    ``collapsed``: the HTML page shows the caption and the figure on request.
    """

    path: Path
    caption: str
    collapsed: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.path, str | Path):
            raise TypeError(f"Figure.path must be a Path, got {type(self.path).__name__}")
        _set(self, "path", Path(self.path))
        _check_str("Figure", "caption", self.caption)


@dataclass(frozen=True, eq=False)
class Table:
    """A data frame shown as a table.

    Floats are shown with 4 significant digits unless ``float_format`` gives a format spec such
    as ``".3f"`` or ``".2e"`` (the part after the colon in ``f"{x:.3f}"``). Integers are shown
    exactly; missing values (None, NA, NaT) as "—" and float NaN as "NaN". A non-default index is
    shown as the first column(s). Tables compare by identity (data frames have no plain ``==``).

    ``key_columns`` names the few columns a reader needs first: the HTML page shows those and
    keeps the whole table behind a toggle (the Markdown and the CSV have every column).
    ``summary`` is the one line shown in place of a long table, which the HTML page collapses
    (more than :data:`LONG_TABLE` rows, or ``collapsed=True``).
    """

    frame: pd.DataFrame
    caption: str
    float_format: str | None = None
    key_columns: tuple[str, ...] = ()
    summary: str = ""
    collapsed: bool | None = None  # None: collapsed when longer than LONG_TABLE rows

    def __post_init__(self) -> None:
        if not isinstance(self.frame, pd.DataFrame):
            raise TypeError(f"Table.frame must be a pandas DataFrame, got {type(self.frame)}")
        _set(self, "frame", self.frame.copy())
        _check_str("Table", "caption", self.caption)
        if self.float_format is not None:
            _check_str("Table", "float_format", self.float_format)
            try:
                format(1.5, self.float_format)
            except ValueError as exc:
                raise ValueError(
                    f"Table.float_format {self.float_format!r} is not a float format spec "
                    f"(use e.g. '.3f' or '.2e'): {exc}"
                ) from None
        _set(self, "key_columns", _as_tuple("Table", "key_columns", self.key_columns, str))
        missing = [c for c in self.key_columns if c not in self.frame.columns]
        if missing:
            raise ValueError(
                f"Table.key_columns {missing} are not columns of the table "
                f"{list(map(str, self.frame.columns))}"
            )
        _check_str("Table", "summary", self.summary)

    @property
    def is_collapsed(self) -> bool:
        return len(self.frame) > LONG_TABLE if self.collapsed is None else self.collapsed

    def key_table(self) -> Table | None:
        """The table with its key columns alone (None when it has none, or only those)."""
        if not self.key_columns or len(self.key_columns) == self.frame.shape[1]:
            return None
        return Table(self.frame[list(self.key_columns)], self.caption, self.float_format)


#: A table with more rows than this is collapsed to its caption and summary on the HTML page.
LONG_TABLE = 12


@dataclass(frozen=True)
class Section:
    """A titled part of the report: text, then tables, then figures, then subsections.

    ``text`` is Markdown-ish: paragraphs separated by blank lines, ``**bold**``, inline
    ```code```, and lines starting with ``"- "`` as bullet lists. The HTML renderer supports
    exactly that subset; the Markdown renderer passes the text through.
    """

    title: str
    text: str = ""
    tables: tuple[Table, ...] = ()
    figures: tuple[Figure, ...] = ()
    subsections: tuple[Section, ...] = ()
    collapsed: bool = False  # the HTML page shows the heading (and summary), the rest on request
    summary: str = ""

    def __post_init__(self) -> None:
        _check_str("Section", "title", self.title, nonempty=True)
        _check_str("Section", "text", self.text)
        _check_str("Section", "summary", self.summary)
        _set(self, "tables", _as_tuple("Section", "tables", self.tables, Table))
        _set(self, "figures", _as_tuple("Section", "figures", self.figures, Figure))
        _set(self, "subsections", _as_tuple("Section", "subsections", self.subsections, Section))


@dataclass(frozen=True)
class Report:
    """A whole report: title, key facts shown first, sections, and provenance shown last.

    ``summary`` is an ordered tuple of ``(label, value)`` strings, e.g.
    ``(("best model", "cubic_xvP"), ("held-out RMSE (one-step)", "0.026 N"))``.
    ``provenance`` maps names to strings (git commit, config hash, package versions, ...).
    ``lead`` is the answer in a few lines, shown first in the summary (section text's Markdown).
    """

    title: str
    summary: tuple[tuple[str, str], ...] = ()
    sections: tuple[Section, ...] = ()
    provenance: Mapping[str, str] = field(default_factory=dict)
    lead: str = ""

    def __post_init__(self) -> None:
        _check_str("Report", "title", self.title, nonempty=True)
        _check_str("Report", "lead", self.lead)
        pairs = _as_tuple("Report", "summary", self.summary, tuple)
        for i, pair in enumerate(pairs):
            if len(pair) != 2 or not all(isinstance(s, str) for s in pair):
                raise TypeError(f"Report.summary[{i}] must be a (label, value) pair of str")
        _set(self, "summary", pairs)
        _set(self, "sections", _as_tuple("Report", "sections", self.sections, Section))
        if not isinstance(self.provenance, Mapping):
            raise TypeError(
                f"Report.provenance must be a mapping, got {type(self.provenance).__name__}"
            )
        for key, value in self.provenance.items():
            if not isinstance(key, str) or not isinstance(value, str):
                raise TypeError(
                    f"Report.provenance entry {key!r}: keys and values must be str "
                    f"(convert numbers and versions with str())"
                )
        _set(self, "provenance", MappingProxyType(dict(self.provenance)))
