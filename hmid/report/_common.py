"""What both renderers share: number formatting, table cells, figure checks, numbering."""

from __future__ import annotations

import inspect
import math
import numbers
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from hmid.report.document import Figure, Report, ReportError, Section, Table

SIGNIFICANT_DIGITS = 4
MISSING = "—"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _exponent(x: float, digits: int) -> int:
    """Decimal exponent of ``x`` after rounding to ``digits`` significant digits (x != 0)."""
    return math.floor(math.log10(abs(float(f"{x:.{digits - 1}e}"))))


def _fixed(exponent: int) -> bool:
    return -3 <= exponent < 6


def format_float(x: float, digits: int = SIGNIFICANT_DIGITS, decimals: int | None = None) -> str:
    """``x`` to ``digits`` significant digits: fixed notation from 1e-3 to 1e6, else scientific.

    Digits left of the decimal point are never rounded away (123456.7 -> "123457"). Given
    ``decimals``, a value in the fixed range is shown with exactly that many decimals instead.
    """
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0" if decimals is None else f"{0:.{decimals}f}"
    exponent = _exponent(x, digits)
    if _fixed(exponent):
        if decimals is None:
            decimals = max(0, digits - 1 - exponent)
        return f"{x:.{decimals}f}"
    mantissa, exp = f"{x:.{digits - 1}e}".split("e")
    return f"{mantissa}e{int(exp)}"


def column_decimals(values: list[float], digits: int = SIGNIFICANT_DIGITS) -> int | None:
    """Common decimals for a column of floats, so the decimal points line up; or None.

    The decimals give every value at least ``digits`` significant digits. None (format each
    value on its own) when that would give the largest value more than ``digits + 2`` digits,
    or when some value needs scientific notation.
    """
    exponents = [_exponent(x, digits) for x in values if math.isfinite(x) and x != 0]
    if not exponents or not all(_fixed(e) for e in exponents):
        return None
    decimals = max(0, digits - 1 - min(exponents))
    return decimals if max(exponents) + 1 + decimals <= digits + 2 else None


def format_value(
    value: object, float_format: str | None = None, decimals: int | None = None
) -> str:
    """One table cell as text (see :class:`hmid.report.Table` for the rules)."""
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        x = float(value)
        if float_format is not None and math.isfinite(x):
            return format(x, float_format)
        return format_float(x, decimals=decimals)
    try:
        if pd.isna(value):
            return MISSING
    except (TypeError, ValueError):  # array-likes: fall through to str()
        pass
    return str(value)


def _column_text(series: pd.Series, float_format: str | None) -> list[str]:
    values = series.tolist()
    decimals = None
    if float_format is None and pd.api.types.is_float_dtype(series.dtype):
        finite = [float(v) for v in values if isinstance(v, float) and math.isfinite(v)]
        if finite and all(v.is_integer() and abs(v) < 1e15 for v in finite):
            decimals = 0  # whole numbers stored as float (an int column with NaN): no ".000"
        else:
            decimals = column_decimals(finite)
    return [format_value(v, float_format, decimals) for v in values]


@dataclass(frozen=True)
class Cells:
    """A table as text: header labels, body rows, and which columns are numeric."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    numeric: tuple[bool, ...]


def _is_numeric(series: pd.Series) -> bool:
    dtype = series.dtype
    return pd.api.types.is_numeric_dtype(dtype) and not pd.api.types.is_bool_dtype(dtype)


def _label(key: object) -> str:
    if isinstance(key, tuple):  # MultiIndex columns
        return " / ".join(str(k) for k in key if str(k) != "")
    return str(key)


def table_cells(table: Table) -> Cells:
    frame = table.frame
    default_index = isinstance(frame.index, pd.RangeIndex) and frame.index.name is None
    if not default_index:
        names = [("" if n is None else str(n)) for n in frame.index.names]
        frame = frame.reset_index(names=[f"__index_{i}" for i in range(len(names))])
        header = [*names, *(_label(c) for c in frame.columns[len(names) :])]
    else:
        header = [_label(c) for c in frame.columns]
    columns = [frame.iloc[:, j] for j in range(frame.shape[1])]
    numeric = tuple(_is_numeric(c) for c in columns)
    text = [_column_text(c, table.float_format) for c in columns]
    rows = tuple(zip(*text, strict=True)) if text else ((),) * len(frame)
    return Cells(tuple(header), rows, numeric)


def section_text(text: str) -> str:
    """The text with indentation common to all lines removed (text written in triple quotes)."""
    return inspect.cleandoc(text.replace("\r\n", "\n")) if text.strip() else ""


def figure_file(figure: Figure, run_dir: Path) -> Path:
    """The figure's file, checked: it exists, is a PNG, and lies inside ``run_dir``."""
    path = figure.path if figure.path.is_absolute() else run_dir / figure.path
    what = f"figure {figure.caption!r} ({figure.path})"
    try:
        path.resolve().relative_to(run_dir.resolve())
    except ValueError:
        raise ReportError(
            f"{what}: not inside the run folder {run_dir}; write figures into the run folder "
            f"so the report keeps working when the folder is moved"
        ) from None
    if not path.is_file():
        raise ReportError(f"{what}: file not found; write the figure before the report")
    with open(path, "rb") as handle:
        if handle.read(8) != PNG_MAGIC:
            raise ReportError(f"{what}: not a PNG file; save figures with format='png'")
    return path


def relative_posix(path: Path, run_dir: Path) -> str:
    return Path(os.path.relpath(path.resolve(), run_dir.resolve())).as_posix()


@dataclass(frozen=True)
class Entry:
    """A section with its number ("2.1") and depth (1 for top-level sections)."""

    section: Section
    number: str
    depth: int


def walk(report: Report) -> Iterator[Entry]:
    """Every section in document order, depth first, numbered 1, 1.1, 1.2, 2, ..."""

    def visit(sections: tuple[Section, ...], prefix: str, depth: int) -> Iterator[Entry]:
        for i, section in enumerate(sections, start=1):
            number = f"{prefix}{i}"
            yield Entry(section, number, depth)
            yield from visit(section.subsections, f"{number}.", depth + 1)

    yield from visit(report.sections, "", 1)
