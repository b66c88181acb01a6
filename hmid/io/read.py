"""Read CSV or Parquet logs (or in-memory tables) into validated :class:`~hmid.io.log.Log` objects.

The table is parsed once with pandas' C parser; only the mapped columns are kept, calibrated,
converted to SI, and checked (see :mod:`hmid.io.validate`). Any malformed input ends in a one-line
:class:`~hmid.errors.LogError`; pandas' and pyarrow's own exceptions never escape.
"""

from __future__ import annotations

import hashlib
import io
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.errors import HmidWarning, LogError, one_line
from hmid.io._csv import WHITESPACE, line_locator, parse_csv
from hmid.io.columns import ColumnMap
from hmid.io.log import Log
from hmid.io.units import to_si
from hmid.io.validate import (
    Place,
    check_finite,
    check_length,
    check_rate,
    check_time,
    locate_column,
    numeric,
    saturation,
)

PARQUET_SUFFIXES = (".parquet", ".pq")
_LOG_SUFFIXES = (".csv", ".tsv", ".txt", ".dat", *PARQUET_SUFFIXES)


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
    _not_a_folder(Path(path), source)
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
        _check_text(data, source)
        frame, columns, sep = parse_csv(data, columns, source)
        meta |= {"format": "csv", "delimiter": "whitespace" if sep == WHITESPACE else sep}
        # the text is read again only to name a bad row's line: a long log is not held twice
        place = Place(source, line_locator(Path(path).read_bytes, columns))
    del data
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
    si, units = {}, {}
    for ch in order:  # the calibrated values are not kept: one channel's at a time
        spec = columns.channels[ch]
        si[ch], units[ch] = to_si(_calibrated(raw[ch], spec), spec.unit, ch, place.source,
                                  column=spec.column)  # fmt: skip
        if np.shares_memory(si[ch], raw[ch]):  # not a view: the parsed table is let go
            si[ch] = si[ch].copy()
    check_length(len(frame), max(columns.min_samples, min_samples or 0), place.source)
    for ch in order:
        check_finite(si[ch], columns.channels[ch].column, ch, place)
    gap_flag = check_time(si["t"], columns.channels["t"].column, columns.max_gap_factor, place)
    # before any filter: a wrong time unit would otherwise surface as a window misfit
    check_rate(si["t"], columns.channels["t"], columns.sample_rate_hz, place)
    flags = [] if gap_flag is None else [gap_flag]
    if gap_flag is not None:
        warnings.warn(gap_flag, HmidWarning, stacklevel=3)
    for ch in order:
        spec = columns.channels[ch]
        flag = saturation(raw[ch], _calibrated(raw[ch], spec), spec, ch, place, columns.saturation)
        if flag is not None:
            flags.append(flag)
    return Log(
        pd.DataFrame(si, columns=order, copy=False),  # no consolidated second copy
        source=place.source,
        units=units,
        flags=tuple(flags),
        meta=meta,
    )


def _calibrated(raw: np.ndarray, spec) -> np.ndarray:
    """``offset + scale * raw`` in the channel's unit; ``raw`` itself for the identity."""
    if spec.offset == 0 and spec.scale == 1:
        return raw
    return spec.offset + spec.scale * raw


def _parse_parquet(data: bytes, source: str) -> pd.DataFrame:
    import pyarrow  # already loaded by pandas' Parquet reader; needed for its exception type

    try:
        return pd.read_parquet(io.BytesIO(data))
    except (ValueError, OSError, pyarrow.ArrowException) as err:
        raise LogError(f"{source}: cannot read as Parquet: {one_line(err)}") from None


def _check_text(data: bytes, source: str) -> None:
    if not data.strip():
        raise LogError(f"{source}: the file is empty; expected a table with a time column")
    if b"\x00" in data:
        raise LogError(
            f"{source}: the file contains NUL bytes, so it is not a text table "
            f"(Parquet files need a {' or '.join(PARQUET_SUFFIXES)} suffix)"
        )


def _not_a_folder(path: Path, source: str) -> None:
    if not path.is_dir():
        return
    names = sorted(
        f.name for f in path.iterdir() if f.is_file() and f.suffix.lower() in _LOG_SUFFIXES
    )
    held = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "") or "no such file"
    raise LogError(
        f"{source}: is a folder, not a log file; give the path of one CSV or Parquet file "
        f"(it holds {held})"
    )
