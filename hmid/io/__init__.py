"""Logs in, validated, in SI units."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hmid._lazy import lazy_exports

if TYPE_CHECKING:
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

# Every re-export's module imports pandas or pydantic: each is resolved on first access (PEP 562),
# so that importing a sibling (hmid.io.log) or hmid itself does not load them all.
_LAZY = {
    "CANONICAL_UNITS": "hmid.io.log",
    "ChannelSpec": "hmid.io.columns",
    "ColumnMap": "hmid.io.columns",
    "Log": "hmid.io.log",
    "format_validation_error": "hmid._messages",
    "load_column_map": "hmid.io.columns",
    "log_from_frame": "hmid.io.read",
    "read_log": "hmid.io.read",
    "si_unit": "hmid.io.units",
    "to_si": "hmid.io.units",
    "unit_registry": "hmid.io.units",
}


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
