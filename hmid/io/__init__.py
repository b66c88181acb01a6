"""Logs in, validated, in SI units."""

from hmid._messages import format_validation_error
from hmid.io.columns import ChannelSpec, ColumnMap, load_column_map
from hmid.io.log import CANONICAL_UNITS, Log
from hmid.io.read import log_from_frame, read_log
from hmid.io.units import si_unit, to_si, unit_registry

__all__ = [
    "CANONICAL_UNITS",
    "ChannelSpec",
    "ColumnMap",
    "Log",
    "format_validation_error",
    "load_column_map",
    "log_from_frame",
    "read_log",
    "si_unit",
    "to_si",
    "unit_registry",
]
