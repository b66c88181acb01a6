"""Read CSV or Parquet logs (or in-memory tables) into validated :class:`~hmid.io.log.Log` objects.

The table is parsed once with pandas' C parser; only the mapped columns are kept, calibrated,
converted to SI, and checked (see :mod:`hmid.io.validate`). Any malformed input ends in a one-line
:class:`~hmid.errors.LogError`; pandas' and pyarrow's own exceptions never escape.
"""

from __future__ import annotations

import hashlib
import io
import re
import warnings
from collections.abc import Iterator, Mapping
from itertools import islice
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.errors import HmidWarning, LogError
from hmid.io.columns import ColumnMap
from hmid.io.log import Log
from hmid.io.units import to_si
from hmid.io.validate import (
    Place,
    RowLocator,
    check_finite,
    check_length,
    check_time,
    locate_column,
    numeric,
    saturation,
)

PARQUET_SUFFIXES = (".parquet", ".pq")
_SNIFF_BYTES = 64 * 1024
_SNIFF_LINES = 20
_DELIMITERS = ("\t", ",", ";", "|")
_WHITESPACE = r"\s+"
_NEWLINES = re.compile(r"\r\n|\r|\n")  # the line ends pandas' C parser accepts


def read_log(
    path: str | Path,
    columns: ColumnMap,
    *,
    min_samples: int | None = None,
) -> Log:
    """Load a CSV (any delimiter, header or not) or Parquet (``.parquet``/``.pq``) log.

    ``min_samples`` raises the column map's minimum (e.g. to the longest filter window the caller
    will apply). ``meta`` records the file, its sha256 and the format; ``flags`` the non-fatal
    findings (saturation).
    """
    source = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as err:
        raise LogError(f"{source}: cannot read the file ({err.strerror or err})") from None
    meta: dict[str, object] = {"file": source, "sha256": hashlib.sha256(data).hexdigest()}
    if Path(path).suffix.lower() in PARQUET_SUFFIXES:
        frame = _parse_parquet(data, source)
        meta["format"] = "parquet"
        place = Place(source)
    else:
        frame, sep = _parse_csv(data, columns, source)
        meta |= {"format": "csv", "delimiter": "whitespace" if sep == _WHITESPACE else sep}
        place = Place(source, _line_locator(data, columns))
    return _build(frame, columns, place, min_samples, meta)


def log_from_frame(
    frame: pd.DataFrame,
    columns: ColumnMap,
    *,
    source: str = "<memory>",
    min_samples: int | None = None,
) -> Log:
    """Validate an in-memory table (e.g. from the simulator) exactly as :func:`read_log` does.

    Columns are found by name (``str``) or position (``int``); rows are reported 1-based with the
    frame's index label.
    """
    if not isinstance(frame, pd.DataFrame):
        raise LogError(f"{source}: expected a pandas DataFrame, got {type(frame).__name__}")
    index = frame.index

    def locate(row: int) -> str:
        label = index[row]
        return f"row {row + 1} (index {label.item() if isinstance(label, np.generic) else label!r})"

    place = Place(source, locate)
    return _build(frame, columns, place, min_samples, {"format": "frame"})


def _build(
    frame: pd.DataFrame,
    columns: ColumnMap,
    place: Place,
    min_samples: int | None,
    meta: Mapping[str, object],
) -> Log:
    # t first, then the other channels in the column map's order
    order = ["t", *(name for name in columns.channels if name != "t")]
    labels = list(frame.columns)
    positions = {ch: locate_column(labels, columns.channels[ch], ch, place) for ch in order}
    raw = {
        ch: numeric(frame.iloc[:, positions[ch]], columns.channels[ch].column, ch, place)
        for ch in order
    }
    calibrated, si, units = {}, {}, {}
    for ch in order:
        spec = columns.channels[ch]
        calibrated[ch] = spec.offset + spec.scale * raw[ch]
        si[ch], units[ch] = to_si(calibrated[ch], spec.unit, ch, place.source, column=spec.column)
    check_length(len(frame), max(columns.min_samples, min_samples or 0), place.source)
    for ch in order:
        check_finite(si[ch], columns.channels[ch].column, ch, place)
    gap_flag = check_time(si["t"], columns.channels["t"].column, columns.max_gap_factor, place)
    flags = [] if gap_flag is None else [gap_flag]
    if gap_flag is not None:
        warnings.warn(gap_flag, HmidWarning, stacklevel=3)
    for ch in order:
        flag = saturation(
            raw[ch], calibrated[ch], columns.channels[ch], ch, place, columns.saturation
        )
        if flag is not None:
            flags.append(flag)
    return Log(
        pd.DataFrame(si, columns=order),
        source=place.source,
        units=units,
        flags=tuple(flags),
        meta=meta,
    )


def _one_line(err: BaseException, limit: int = 200) -> str:
    text = " ".join(str(err).split()) or type(err).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _parse_parquet(data: bytes, source: str) -> pd.DataFrame:
    import pyarrow  # already loaded by pandas' Parquet reader; needed for its exception type

    try:
        return pd.read_parquet(io.BytesIO(data))
    except (ValueError, OSError, pyarrow.ArrowException) as err:
        raise LogError(f"{source}: cannot read as Parquet: {_one_line(err)}") from None


def _parse_csv(data: bytes, columns: ColumnMap, source: str) -> tuple[pd.DataFrame, str]:
    if not data.strip():
        raise LogError(f"{source}: the file is empty; expected a table with a time column")
    if b"\x00" in data:
        raise LogError(
            f"{source}: the file contains NUL bytes, so it is not a text table "
            f"(Parquet files need a {' or '.join(PARQUET_SUFFIXES)} suffix)"
        )
    sep = columns.sep or _sniff(data, columns)
    try:
        with warnings.catch_warnings():
            # pandas only warns when data rows are wider than the header, and drops the excess
            warnings.simplefilter("error", pd.errors.ParserWarning)
            frame = pd.read_csv(
                io.BytesIO(data),
                sep=sep,
                header=0 if columns.header else None,
                skiprows=columns.skip_rows,
                comment=columns.comment,
                index_col=False,
                engine="c",
                encoding="utf-8",
                low_memory=False,
            )
    except pd.errors.EmptyDataError:
        raise LogError(
            f"{source}: no table found (no data lines after skip_rows={columns.skip_rows})"
        ) from None
    except pd.errors.ParserWarning:
        raise LogError(
            f"{source}: some data rows have more fields than the header; "
            "check the delimiter or the header line"
        ) from None
    except UnicodeDecodeError:
        raise LogError(f"{source}: {_not_utf8(data)}, so it is not a CSV table") from None
    except (ValueError, OverflowError) as err:  # pandas' ParserError is a ValueError
        raise LogError(f"{source}: cannot parse as a table: {_one_line(err)}") from None
    if columns.header:
        _check_unique_header(data, sep, columns, source)
        frame.columns = [str(label).strip() for label in frame.columns]
    return frame, sep


def _check_unique_header(data: bytes, sep: str, columns: ColumnMap, source: str) -> None:
    """pandas renames a repeated header name ('P', 'P.1'); a mapped name must be unambiguous."""
    header = pd.read_csv(
        io.BytesIO(data), sep=sep, header=None, nrows=1, skiprows=columns.skip_rows,
        comment=columns.comment, dtype=str, engine="c",
    ).iloc[0]  # fmt: skip
    names = [str(cell).strip() for cell in header]
    for channel, spec in columns.channels.items():
        hits = [i for i, name in enumerate(names) if name == spec.column]
        if len(hits) > 1:
            raise LogError(
                f"{source}: column {spec.column!r} (channel {channel}) appears {len(hits)} times "
                f"in the header (positions {hits}); rename one, or map by position with "
                "header: false"
            )


def _not_utf8(data: bytes) -> str:
    # pandas decodes in chunks, so its error position is not the file's; find the file's
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        return f"line {line} (byte {err.start}) is not UTF-8 text"
    return "the file is not UTF-8 text"


def _content_lines(data: bytes, columns: ColumnMap) -> Iterator[tuple[int, str]]:
    """(1-based line number, text) of the lines pandas reads: after ``skip_rows``, not blank,
    not comments. Quoted fields spanning lines are not accounted for."""
    text = data.decode("utf-8", errors="replace")
    for number, line in enumerate(_NEWLINES.split(text), start=1):
        if number <= columns.skip_rows or not line.strip():
            continue
        if columns.comment and line.startswith(columns.comment):
            continue
        yield number, line


def _sniff(data: bytes, columns: ColumnMap) -> str:
    """The delimiter of the first lines: a character found equally often on every line."""
    head = data[:_SNIFF_BYTES]
    if len(data) > _SNIFF_BYTES:
        head = head[: max(head.rfind(b"\n"), 0)]  # drop the line cut in two
    lines = [line for _, line in islice(_content_lines(head, columns), _SNIFF_LINES)]
    if not lines:
        return ","
    consistent = {
        d: lines[0].count(d)
        for d in _DELIMITERS
        if lines[0].count(d) > 0 and all(line.count(d) == lines[0].count(d) for line in lines)
    }
    if consistent:
        return max(consistent, key=consistent.__getitem__)
    widths = {len(line.split()) for line in lines}
    if len(widths) == 1 and widths.pop() > 1:
        return _WHITESPACE
    # ragged lines: go by the first line and let the parser / the NaN check point at the rows
    best = max(_DELIMITERS, key=lines[0].count)
    if lines[0].count(best):
        return best
    return _WHITESPACE if len(lines[0].split()) > 1 else ","


def _line_locator(data: bytes, columns: ColumnMap) -> RowLocator:
    """Describe a data row as ``"row N (line L)"``; the line map is built on first use only."""
    lines: list[int] = []

    def locate(row: int) -> str:
        if not lines:
            lines.extend(_data_line_numbers(data, columns))
        line = f" (line {lines[row]})" if row < len(lines) else ""
        return f"row {row + 1}{line}"

    return locate


def _data_line_numbers(data: bytes, columns: ColumnMap) -> list[int]:
    """1-based file line of each data row."""
    numbers = [number for number, _ in _content_lines(data, columns)]
    return numbers[1:] if columns.header else numbers
