"""Checks that turn a raw table into trustworthy channels, or say in one line why not.

Every check raises :class:`~hmid.errors.LogError` naming the file, the column and channel, the row
(1-based data row, plus the file line for text files) and the fix. Nothing here drops, clips or
fills data: a check either passes the values through or stops.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.errors import HmidWarning, LogError
from hmid.io.columns import ChannelSpec
from hmid.io.units import to_si

#: Turns a 0-based data row into its description, e.g. ``"row 153 (line 154)"``.
RowLocator = Callable[[int], str]


def plain_rows(row: int) -> str:
    """``"row N"`` with N 1-based: for tables without file lines (Parquet)."""
    return f"row {row + 1}"


@dataclass(frozen=True)
class Place:
    """Where a finding is: the source, and how to describe a row of it."""

    source: str
    locate: RowLocator = plain_rows

    def at(self, column: str | int, channel: str, row: int | None = None) -> str:
        """``"<source>: column 'c' (channel P): row 5 (line 6): "``."""
        text = f"{self.source}: column {column!r} (channel {channel}): "
        return text + (f"{self.locate(row)}: " if row is not None else "")


def _short(text: object, limit: int = 30) -> str:
    text = repr(text)
    return text if len(text) <= limit else text[: limit - 4] + "...'"


def locate_column(labels: Sequence[object], spec: ChannelSpec, channel: str, where: Place) -> int:
    """Position of the channel's column among ``labels``; LogError if it is not there."""
    if isinstance(spec.column, int):
        if spec.column < len(labels):
            return spec.column
        have = f"positions 0 to {len(labels) - 1}" if labels else "none"
        raise LogError(
            f"{where.at(spec.column, channel)}the table has only {len(labels)} column(s) "
            f"({have}); fix the position or the delimiter"
        )
    hits = [i for i, label in enumerate(labels) if label == spec.column]
    if len(hits) == 1:
        return hits[0]
    if hits:
        raise LogError(
            f"{where.at(spec.column, channel)}the column name appears {len(hits)} times; "
            "rename the duplicates or map the column by position"
        )
    names = [str(label) for label in labels]
    listed = ", ".join(repr(n) for n in names[:20]) + (", ..." if len(names) > 20 else "")
    raise LogError(
        f"{where.at(spec.column, channel)}no such column; the table has {len(names)} "
        f"column(s): {listed}; fix 'column' in the column map"
    )


def numeric(series: pd.Series, column: str | int, channel: str, where: Place) -> np.ndarray:
    """The column as float64; LogError at the first cell that is not a number."""
    dtype = series.dtype
    if pd.api.types.is_bool_dtype(dtype) or pd.api.types.is_complex_dtype(dtype):
        raise LogError(f"{where.at(column, channel)}values are {dtype}, not real numbers")
    if pd.api.types.is_numeric_dtype(dtype):
        return series.to_numpy(dtype="float64", na_value=np.nan)
    if not (pd.api.types.is_object_dtype(dtype) or pd.api.types.is_string_dtype(dtype)):
        raise LogError(f"{where.at(column, channel)}values are {dtype}, not numbers")
    cells = series.to_numpy(dtype=object)
    try:
        values = pd.to_numeric(pd.Series(cells), errors="coerce").to_numpy()
        values = np.asarray(values, dtype="float64")
        bad = np.flatnonzero(np.isnan(values) & pd.notna(cells))
    except (TypeError, ValueError):  # cells pandas cannot even coerce (lists, dicts, ...)
        bad = np.asarray([i for i, c in enumerate(cells) if not _is_number(c)], dtype=int)
        if not len(bad):
            values = np.asarray([np.nan if pd.isna(c) else float(c) for c in cells], "float64")
    if len(bad):
        row = int(bad[0])
        if isinstance(cells[row], str) and _DECIMAL_COMMA.match(cells[row]):
            raise LogError(
                f"{where.at(column, channel, row)}value {_short(cells[row])} has a decimal comma "
                f'({len(bad)} such cell(s) in this column); set decimal: "," in the column map'
            )
        raise LogError(
            f"{where.at(column, channel, row)}non-numeric value {_short(cells[row])} "
            f"({len(bad)} such cell(s) in this column); fix the cell or the delimiter"
        )
    return values


# '1,25', '-0,5e-3', '1.234,5': a number written with a decimal comma
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?(\d{1,3}(\.\d{3})*|\d+)?,\d+([eE][+-]?\d+)?\s*$")


def _is_number(cell: object) -> bool:
    if cell is None or cell is pd.NA or (isinstance(cell, float) and math.isnan(cell)):
        return True  # missing: left for the NaN check, which reports it as such
    try:
        float(cell)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False
    return not isinstance(cell, bool)


def check_finite(values: np.ndarray, column: str | int, channel: str, where: Place) -> None:
    """LogError at the first NaN or ±inf, with how many there are."""
    bad = np.flatnonzero(~np.isfinite(values))
    if len(bad):
        row = int(bad[0])
        what = "missing/NaN" if np.isnan(values[row]) else f"{values[row]}"
        raise LogError(
            f"{where.at(column, channel, row)}value is {what}; {len(bad)} non-finite value(s) "
            "in this column; fix or remove those rows (hmid does not fill or drop samples)"
        )


def check_length(n: int, needed: int, source: str) -> None:
    """LogError if the table has fewer than ``needed`` samples."""
    if n < needed:
        raise LogError(
            f"{source}: only {n} sample(s), at least {needed} are needed (min_samples); "
            "use a longer log or shorter filter windows"
        )


#: Accepted gaps longer than this many median steps are reported in ``Log.flags``.
GAP_FLAG_FACTOR = 3.0


def check_time(t: np.ndarray, column: str | int, max_gap_factor: float, where: Place) -> str | None:
    """LogError if time (s) does not strictly increase or has a gap > max_gap_factor x median dt.

    Returns a flag (one line) when accepted gaps exceed :data:`GAP_FLAG_FACTOR` median steps, so a
    long gap that a permissive column map lets through still shows in the log's findings.
    """
    dt = np.diff(t)
    back = np.flatnonzero(dt <= 0)
    if len(back):
        i = int(back[0])
        kind = "repeats" if dt[i] == 0 else "goes back from"
        raise LogError(
            f"{where.at(column, 't', i + 1)}time {kind} the previous row: t = {t[i]:.9g} s then "
            f"{t[i + 1]:.9g} s ({len(back)} such step(s)); time must strictly increase: "
            "remove duplicated or out-of-order rows"
        )
    if len(dt) == 0:
        return None
    median = float(np.median(dt))
    worst = int(np.argmax(dt))
    ratio = float(dt[worst]) / median
    if ratio > max_gap_factor:
        raise LogError(
            f"{where.at(column, 't', worst + 1)}gap of {dt[worst]:.4g} s before this row is "
            f"{ratio:.1f} x the median step {median:.4g} s (median rate {1 / median:.4g} Hz, "
            f"max_gap_factor {max_gap_factor:g}); set max_gap_factor >= {math.ceil(ratio)} "
            "in the column map to accept this log"
        )
    long_gaps = int(np.count_nonzero(dt > GAP_FLAG_FACTOR * median))
    if long_gaps == 0:
        return None
    return (
        f"{where.at(column, 't', worst + 1)}{long_gaps} gap(s) longer than "
        f"{GAP_FLAG_FACTOR:g} x the median step {median:.4g} s, worst {dt[worst]:.4g} s "
        f"({ratio:.1f} x) before this row; filters and derivatives bridge them"
    )


#: Time units a time column is likely to be in; the wrong one is looked for among them.
_TIME_UNITS = ("s", "ms", "us", "ns")


def check_rate(
    t: np.ndarray, spec: ChannelSpec, plausible: tuple[float, float], where: Place
) -> None:
    """LogError if the median sampling rate of ``t`` (s) is outside ``plausible`` (Hz).

    A rate far outside the rig's range almost always means a wrong time unit (seconds mapped as
    'ms' read a 1 kHz log as 1 MHz); the message names the unit that gives a plausible rate.
    """
    if len(t) < 2:
        return
    low, high = plausible
    rate = 1.0 / float(np.median(np.diff(t)))
    if low <= rate <= high:
        return
    found = (
        f"{where.at(spec.column, 't')}median sampling rate {rate:.4g} Hz ({len(t)} samples in "
        f"{t[-1] - t[0]:.4g} s) is outside the plausible {low:g} to {high:g} Hz"
    )
    unit = _plausible_unit(rate, spec.unit, plausible)
    if unit is None:
        raise LogError(
            f"{found}; check channels.t.unit and scale in the column map, or set sample_rate_hz: "
            f"[low, high] there if the rig really samples at {rate:.4g} Hz"
        )
    raise LogError(
        f"{found}; time looks like {unit} mapped as {spec.unit!r}: set channels.t.unit: {unit} in "
        f"the column map (or sample_rate_hz: [low, high] there if the rig really samples at "
        f"{rate:.4g} Hz)"
    )


def _plausible_unit(rate: float, unit: str, plausible: tuple[float, float]) -> str | None:
    """The time unit that would put ``rate`` (read in ``unit``) nearest the middle (in decades)
    of the plausible range, or None if none puts it inside."""
    seconds = {u: float(to_si(np.ones(1), u, "t", "")[0][0]) for u in (*_TIME_UNITS, unit)}
    middle = math.sqrt(plausible[0] * plausible[1])
    best, distance = None, math.inf
    for candidate in _TIME_UNITS:
        moved = rate * seconds[unit] / seconds[candidate]
        if plausible[0] <= moved <= plausible[1] and abs(math.log(moved / middle)) < distance:
            best, distance = candidate, abs(math.log(moved / middle))
    return best


def saturation(
    raw: np.ndarray,
    calibrated: np.ndarray,
    spec: ChannelSpec,
    channel: str,
    where: Place,
    mode: str,
) -> str | None:
    """A flag for samples at the sensor's rails (raises instead when ``mode == 'error'``).

    Rails are raw counts 0 or 2**adc_bits - 1 (``adc_bits``), and values at or beyond the ends of
    ``range`` in the channel's unit (``range``). Returns None if no sample is at a rail.
    """
    at_rail = np.zeros(len(raw), dtype=bool)
    rails = []
    if spec.adc_bits is not None:
        top = 2**spec.adc_bits - 1
        at_rail |= (raw <= 0) | (raw >= top)
        rails.append(f"raw count 0 or {top}")
    if spec.range is not None:
        low, high = spec.range
        at_rail |= (calibrated <= low) | (calibrated >= high)
        rails.append(f"range ends {low:g} or {high:g} {spec.unit}")
    hits = np.flatnonzero(at_rail)
    if not len(hits):
        return None
    row = int(hits[0])
    message = (
        f"{where.at(spec.column, channel, row)}{len(hits)} sample(s) at the sensor rails "
        f"({' / '.join(rails)}), first here; the signal is saturated there"
    )
    if mode == "error":
        raise LogError(f"{message}; re-record within the sensor range or set saturation: flag")
    warnings.warn(message, HmidWarning, stacklevel=4)
    return message
