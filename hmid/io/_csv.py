"""CSV text into a table (private to :mod:`hmid.io.read`).

The table is parsed once with pandas' C parser. What exports get wrong (the delimiter, decimal
commas, ``#`` comment lines, Excel's ``sep=;`` first line, a non-UTF-8 encoding, a ragged line)
ends in a one-line :class:`~hmid.errors.LogError` naming the file line and the column-map key
that fixes it; pandas' own wording never escapes.
"""

from __future__ import annotations

import codecs
import io
import re
import warnings
from collections.abc import Callable, Iterator
from itertools import islice
from typing import AnyStr

import pandas as pd

from hmid.errors import LogError, one_line
from hmid.io.columns import ColumnMap
from hmid.io.validate import RowLocator

_SNIFF_BYTES = 64 * 1024
_SNIFF_LINES = 20
_DELIMITERS = ("\t", ",", ";", "|")
WHITESPACE = r"\s+"
_NEWLINES = re.compile(r"\r\n|\r|\n")  # the line ends pandas' C parser accepts
_NAMES = {"\t": "tab", ",": "comma", ";": "semicolon", "|": "pipe", WHITESPACE: "whitespace"}
# Excel writes 'sep=;' as the first line of a CSV to say which delimiter it used
_EXCEL_SEP = re.compile(rb"^(?:\xef\xbb\xbf)?sep=([\t!-~])[ \t]*(?:\r\n|\r|\n)")
_EXPECTED_FIELDS = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def parse_csv(data: bytes, columns: ColumnMap, source: str) -> tuple[pd.DataFrame, ColumnMap, str]:
    """``(table, column map as applied, pandas sep)``; an Excel ``sep=`` line is honoured, so the
    map returned may skip it and name its delimiter."""
    columns = _honour_excel_sep_line(data, columns, source)
    _check_comment_lines(data, columns, source)
    sep = columns.sep or _sniff(data, columns)
    try:
        with warnings.catch_warnings():
            # pandas only warns when data rows are wider than the header, and drops the excess
            warnings.simplefilter("error", pd.errors.ParserWarning)
            # parsed in chunks (the whole file's tokens at once peaked at 4.5x a long log's
            # float64 size); a column mixed across chunks is checked cell by cell after
            warnings.simplefilter("ignore", pd.errors.DtypeWarning)
            frame = pd.read_csv(
                io.BytesIO(data),
                sep=sep,
                header=0 if columns.header else None,
                skiprows=columns.skip_rows,
                comment=columns.comment,
                decimal=columns.decimal,
                index_col=False,
                engine="c",
                encoding=columns.encoding,
                low_memory=True,
            )
    except pd.errors.EmptyDataError:
        raise LogError(
            f"{source}: no table found (no data lines after skip_rows={columns.skip_rows})"
        ) from None
    except pd.errors.ParserWarning:
        raise LogError(f"{source}: {_wider_rows(data, columns, sep)}") from None
    except UnicodeDecodeError:
        raise LogError(f"{source}: {_undecodable(data, columns.encoding)}") from None
    except pd.errors.ParserError as err:
        raise LogError(f"{source}: {_ragged(err, columns)}") from None
    except (ValueError, OverflowError) as err:
        raise LogError(f"{source}: cannot parse as a table: {one_line(err)}") from None
    if columns.header:
        _check_unique_header(data, sep, columns, source)
        frame.columns = [str(label).strip() for label in frame.columns]
    _check_one_column(frame, data, columns, sep, source)
    return frame, columns, sep


def _yaml(delimiter: str) -> str:
    """How to write the delimiter in the column map."""
    if delimiter == WHITESPACE:
        return "whitespace"
    return '"\\t"' if delimiter == "\t" else f'"{delimiter}"'


def _honour_excel_sep_line(data: bytes, columns: ColumnMap, source: str) -> ColumnMap:
    match = _EXCEL_SEP.match(data)
    if match is None or columns.skip_rows > 0:  # a skipped first line is the user's to skip
        return columns
    sep = match.group(1).decode("ascii")
    shown = "\\t" if sep == "\t" else sep
    if columns.sep is not None and columns.sep != sep:
        raise LogError(
            f"{source}: line 1 says sep={shown} (Excel's delimiter line) but the column map says "
            f"delimiter: {_yaml(columns.sep)}; remove one of them"
        )
    if sep in (columns.decimal, columns.comment, '"'):
        raise LogError(
            f"{source}: line 1 says sep={shown} (Excel's delimiter line), but {shown!r} is the "
            "column map's decimal or comment character; fix the export or the column map"
        )
    return columns.model_copy(update={"delimiter": sep, "skip_rows": 1})


def _check_comment_lines(data: bytes, columns: ColumnMap, source: str) -> None:
    if columns.comment is not None or b"#" not in data:
        return
    for number, line in _content_lines(data, columns):
        if line.lstrip().startswith("#"):
            raise LogError(
                f"{source}: line {number} starts with '#' but the column map sets no comment "
                'character: set comment: "#" in the column map to skip such lines'
            )


def _check_one_column(
    frame: pd.DataFrame, data: bytes, columns: ColumnMap, sep: str, source: str
) -> None:
    """One column, while the first line holds another delimiter: the delimiter is wrong."""
    if frame.shape[1] != 1:
        return
    label = frame.columns[0]
    if all(spec.column in (0, label) for spec in columns.channels.values()):
        return  # everything the map asks for is there
    lines = [line for _, line in islice(_content_lines(data, columns), 2)]
    first = lines[0] if lines else ""
    others = [d for d in _DELIMITERS if d not in (sep, columns.decimal) and d in first]
    blanks = {len(line.split()) for line in lines}  # 'time (s)' alone is not blank-separated
    if others:
        other = max(others, key=first.count)
    elif sep != WHITESPACE and len(lines) == 2 and len(blanks) == 1 and blanks.pop() > 1:
        other = WHITESPACE
    else:
        return
    name, line = _NAMES[other], "header" if columns.header else "first"
    raise LogError(
        f"{source}: only one column when lines are split at {_NAMES.get(sep, repr(sep))}, but "
        f"the {line} line contains {'blanks' if other == WHITESPACE else name + 's'}: is the "
        f"delimiter {name}? set delimiter: {_yaml(other)} in the column map"
    )


def _fields(line: str, sep: str) -> int:
    return len(line.split()) if sep == WHITESPACE else line.count(sep) + 1


def _mismatch(line: int, saw: int, expected: int, columns: ColumnMap) -> str:
    first = "the header" if columns.header else "the first row"
    return (
        f"line {line} has {saw} fields where {first} has {expected}; check the delimiter/quoting "
        "of that line"
    )


def _wider_rows(data: bytes, columns: ColumnMap, sep: str) -> str:
    """Data rows wider than the header: the first such line (quotes not accounted for)."""
    lines = _content_lines(data, columns)
    _, head = next(lines, (0, ""))
    width = _fields(head, sep)
    for number, line in lines:
        if _fields(line, sep) > width:
            return _mismatch(number, _fields(line, sep), width, columns)
    return "some data rows have more fields than the header; check the delimiter or the header line"


def _ragged(err: pd.errors.ParserError, columns: ColumnMap) -> str:
    """pandas' tokenizer error as the file line, its field count and the fix."""
    match = _EXPECTED_FIELDS.search(str(err))
    if match is not None:
        expected, line, saw = (int(g) for g in match.groups())
        return _mismatch(line, saw, expected, columns)
    detail = one_line(err).removeprefix("Error tokenizing data. C error: ")
    return f"cannot parse as a table: {detail}; check the delimiter and quoting"


def _check_unique_header(data: bytes, sep: str, columns: ColumnMap, source: str) -> None:
    """pandas renames a repeated header name ('P', 'P.1'); a mapped name must be unambiguous."""
    header = pd.read_csv(
        io.BytesIO(data), sep=sep, header=None, nrows=1, skiprows=columns.skip_rows,
        comment=columns.comment, dtype=str, engine="c", encoding=columns.encoding,
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


def _undecodable(data: bytes, encoding: str) -> str:
    # pandas decodes in chunks, so its error position is not the file's; find the file's
    try:
        data.decode(encoding)
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        where = f"line {line} (byte {err.start})"
    else:
        where = "the file"
    name = "UTF-8" if encoding.lower().replace("_", "-") in ("utf-8", "utf8") else encoding
    return (
        f"{where} is not {name} text: re-save the file as UTF-8 or set encoding: latin-1 in the "
        "column map (cp1252 for Windows exports)"
    )


def _content_lines(data: bytes, columns: ColumnMap) -> Iterator[tuple[int, str]]:
    """(1-based line number, text) of the lines pandas reads: after ``skip_rows``, not blank,
    not comments. Quoted fields spanning lines are not accounted for."""
    for number, line in enumerate(_lines(data, columns.encoding), start=1):
        if number <= columns.skip_rows or not line.strip():
            continue
        if columns.comment and line.startswith(columns.comment):
            continue
        yield number, line


#: Encodings whose line ends are the single bytes CR and LF, never part of another character
_BYTE_LINE_ENDS = ("utf-8", "ascii", "iso8859-1", "cp1252")
_NEWLINE_BYTES = re.compile(rb"\r\n|\r|\n")


def _lines(data: bytes, encoding: str) -> Iterator[str]:
    """The text's lines (split where :data:`_NEWLINES` matches), made as they are read and, in
    an encoding of :data:`_BYTE_LINE_ENDS`, decoded one at a time: a long log's text is never
    held whole, nor as a list of its lines."""
    if codecs.lookup(encoding).name in _BYTE_LINE_ENDS:
        for line in _split(data, _NEWLINE_BYTES):
            yield line.decode(encoding, errors="replace")
    else:
        yield from _split(data.decode(encoding, errors="replace"), _NEWLINES)


def _split(text: AnyStr, ends: re.Pattern[AnyStr]) -> Iterator[AnyStr]:
    """``ends.split(text)``, one piece at a time."""
    start = 0
    for end in ends.finditer(text):
        yield text[start : end.start()]
        start = end.end()
    yield text[start:]


def _sniff(data: bytes, columns: ColumnMap) -> str:
    """The delimiter of the first lines: a character found equally often on every line."""
    head = data[:_SNIFF_BYTES]
    if len(data) > _SNIFF_BYTES:
        head = head[: max(head.rfind(b"\n"), 0)]  # drop the line cut in two
    lines = [line for _, line in islice(_content_lines(head, columns), _SNIFF_LINES)]
    if not lines:
        return ","
    candidates = [d for d in _DELIMITERS if d != columns.decimal]  # '1,25;3,5' splits at ';'
    consistent = {
        d: lines[0].count(d)
        for d in candidates
        if lines[0].count(d) > 0 and all(line.count(d) == lines[0].count(d) for line in lines)
    }
    if consistent:
        return max(consistent, key=consistent.__getitem__)
    widths = {len(line.split()) for line in lines}
    if len(widths) == 1 and widths.pop() > 1:
        return WHITESPACE
    # ragged lines: go by the first line and let the parser / the NaN check point at the rows
    best = max(candidates, key=lines[0].count)
    if lines[0].count(best):
        return best
    return WHITESPACE if len(lines[0].split()) > 1 else ","


def line_locator(read: Callable[[], bytes], columns: ColumnMap) -> RowLocator:
    """Describe a data row as ``"row N (line L)"``; the line map is built on first use only, from
    the text ``read()`` returns (so that a long log's bytes need not be held until then)."""
    found: dict[int, int | None] = {}

    def locate(row: int) -> str:
        if row not in found:
            found[row] = _data_line_number(read(), columns, row)
        line = "" if found[row] is None else f" (line {found[row]})"
        return f"row {row + 1}{line}"

    return locate


def _data_line_number(data: bytes, columns: ColumnMap, row: int) -> int | None:
    """1-based file line of data row ``row`` (0-based; None past the last), the lines before it
    read one at a time: no map of a long log's lines is made."""
    numbers = (number for number, _ in _content_lines(data, columns))
    if columns.header:
        next(numbers, None)
    return next(islice(numbers, row, None), None)
