"""The column map: which file columns become which log channels, in which units.

A column map is a small YAML file (``configs/logs/*.yaml``) validated by pydantic; unknown keys and
impossible values are errors at load time that name the file and the key.
"""

from __future__ import annotations

import codecs
import math
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from hmid.config import load_yaml_model
from hmid.errors import ConfigError, UnitError
from hmid.io.units import si_unit

_WHITESPACE = "whitespace"


class ChannelSpec(BaseModel):
    """Where one channel is in the file and how to turn its values into physical units.

    The value in ``unit`` is ``offset + scale * raw``; the identity by default.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    column: str | int  # header name, or 0-based position (needed for headerless files)
    unit: str  # unit of offset + scale * raw, e.g. 'ms', 'bar', 'mm', 'V', 'count'
    offset: float = 0.0
    scale: float = 1.0
    adc_bits: int | None = Field(default=None, ge=1, le=32, strict=True)  # raw = ADC counts
    range: tuple[float, float] | None = None  # sensor full scale in `unit` (after calibration)

    @field_validator("column", mode="before")
    @classmethod
    def _column_is_name_or_position(cls, value: object) -> object:
        # checked before pydantic's union so that True or 1.5 are not quietly turned into 1
        if isinstance(value, str) and value.strip():
            return value
        if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
            return value
        raise ValueError("column must be a header name or a 0-based position (integer >= 0)")

    @field_validator("offset", "scale")
    @classmethod
    def _finite(cls, value: float) -> float:
        if not math.isfinite(value):
            raise ValueError("must be a finite number")
        return value

    @field_validator("scale")
    @classmethod
    def _nonzero(cls, value: float) -> float:
        if value == 0:
            raise ValueError("scale must not be 0 (it would erase the signal)")
        return value

    @field_validator("range")
    @classmethod
    def _ordered(cls, value: tuple[float, float] | None) -> tuple[float, float] | None:
        if value is not None and not (math.isfinite(value[0]) and value[0] < value[1] < math.inf):
            raise ValueError("range must be [low, high] with finite low < high")
        return value


class ColumnMap(BaseModel):
    """How to read one family of log files into a :class:`~hmid.io.log.Log`."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    channels: dict[str, ChannelSpec]  # channel name -> spec; 't' is required
    delimiter: str | None = None  # one character or 'whitespace'; None = sniff from the file
    header: bool = True  # first (non-skipped) line holds column names
    comment: str | None = None  # lines starting with this character are ignored
    decimal: str = "."  # decimal mark: ',' for decimal-comma exports ("1,25;3,5")
    encoding: str = "utf-8"  # text encoding, e.g. latin-1 or cp1252 for old Windows exports
    skip_rows: int = Field(default=0, ge=0)  # lines to skip before the header / first data row
    max_gap_factor: float = Field(default=10.0, gt=1.0)  # worst dt allowed, in median dts
    min_samples: int = Field(default=2, ge=2)
    saturation: Literal["flag", "error"] = "flag"  # what samples at the sensor rails cause
    # the rig's plausible median sampling rate: outside it, the time unit is likely wrong
    sample_rate_hz: tuple[float, float] = (1.0, 100_000.0)

    @field_validator("delimiter")
    @classmethod
    def _one_character(cls, value: str | None) -> str | None:
        if value is None or value == _WHITESPACE:
            return value
        if len(value) != 1 or value in '"\r\n':
            raise ValueError("delimiter must be one character (e.g. ',' or '\\t') or 'whitespace'")
        return value

    @field_validator("comment")
    @classmethod
    def _comment_character(cls, value: str | None) -> str | None:
        if value is not None and (len(value) != 1 or value in '"\r\n'):
            raise ValueError("comment must be one character, e.g. '#'")
        return value

    @field_validator("decimal")
    @classmethod
    def _decimal_character(cls, value: str) -> str:
        if len(value) != 1 or value in '"\r\n' or value.isalnum() or value.isspace():
            raise ValueError("decimal must be one character, '.' or ','")
        return value

    @field_validator("encoding")
    @classmethod
    def _ascii_compatible(cls, value: str) -> str:
        try:
            name = codecs.lookup(value).name
        except LookupError:
            raise ValueError(f"unknown encoding {value!r}; e.g. utf-8, latin-1, cp1252") from None
        # delimiters, digits and line ends are found byte-wise (sniffing, NUL check, line numbers)
        probe = "\t,;|#.+-eE0123456789\r\n"
        if name != "utf-8-sig" and probe.encode(value, errors="replace") != probe.encode("ascii"):
            raise ValueError(
                f"encoding {value!r} is not ASCII-compatible; re-save the file as UTF-8"
            )
        return value

    @field_validator("sample_rate_hz")
    @classmethod
    def _rate_range(cls, value: tuple[float, float]) -> tuple[float, float]:
        if not (0 < value[0] < value[1] < math.inf):
            raise ValueError("sample_rate_hz must be [low, high] in Hz with 0 < low < high")
        return value

    @field_validator("channels")
    @classmethod
    def _named_with_time(cls, value: dict[str, ChannelSpec]) -> dict[str, ChannelSpec]:
        if "t" not in value:
            raise ValueError("channels must include the time channel 't'")
        for name in value:
            if not name.isidentifier():
                raise ValueError(f"channel name {name!r} must be an identifier (e.g. P, x_raw)")
        return value

    @model_validator(mode="after")
    def _consistent(self) -> ColumnMap:
        for name, spec in self.channels.items():
            if not self.header and isinstance(spec.column, str):
                raise ValueError(
                    f"channel {name!r} names column {spec.column!r} but header is false; "
                    "give 0-based column positions for headerless files"
                )
        if self.comment is not None and self.comment == self.delimiter:
            raise ValueError("comment and delimiter must differ")
        if self.decimal in (self.delimiter, self.comment):
            what = "delimiter" if self.decimal == self.delimiter else "comment"
            raise ValueError(f"decimal and {what} must differ")
        return self

    @property
    def sep(self) -> str | None:
        """The delimiter as pandas' ``sep`` (None = sniff)."""
        return r"\s+" if self.delimiter == _WHITESPACE else self.delimiter


def load_column_map(path: str | Path) -> ColumnMap:
    """Read and validate a column map from YAML; any problem is a one-line :class:`ConfigError`.

    Units are checked here too, so a wrong unit is reported at load time with its key.
    """
    source = str(path)
    if Path(path).is_dir():
        raise ConfigError(
            f"{source}: is a folder, not a column map; give the path of its YAML file"
        )
    columns = load_yaml_model(path, ColumnMap, "column map", " with a 'channels' key")
    for name, spec in columns.channels.items():
        try:
            si_unit(spec.unit, name)
        except UnitError as err:
            raise ConfigError(f"{source}: key 'channels.{name}.unit': {err}") from None
    return columns
