"""Unit conversion of log channels to SI with pint.

Canonical channels (``hmid.io.log.CANONICAL_UNITS``) are converted to their fixed SI unit and must
have the matching dimension; any other channel is converted to the coherent SI unit of its
dimension. Pressures are gauge: they are scaled, never offset by an atmosphere.
"""

from __future__ import annotations

import os
from functools import cache, lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from filelock import FileLock

from hmid.errors import UnitError
from hmid.io.log import CANONICAL_UNITS

if TYPE_CHECKING:
    import pint

#: Unit spellings to suggest, per canonical channel, when a unit is unknown or of the wrong kind.
EXAMPLES: dict[str, str] = {
    "t": "s, ms",
    "P": "Pa, kPa, bar, psi",
    "x": "m, mm",
    "v": "m/s, mm/s",
    "a": "m/s^2, g0",
    "F": "N, kN, lbf",
}
_OTHER_EXAMPLES = "s, ms, mm, kPa, bar, N, V, m/s, count"

# Coherent SI units by which non-canonical channels are reported, tried in order; a dimension not
# listed falls back to pint's compact base-unit string (e.g. 'kg*m**2/s**2').
_NAMED_SI = ("s", "m", "kg", "A", "K", "m/s", "m/s^2", "Pa", "N", "V", "J", "W", "ohm", "1/s")

# Names for dimensions in messages; pint alone would say '[mass] / [length] / [time] ** 2'.
_DIMENSION_NAMES = {
    "s": "[time]",
    "m": "[length]",
    "kg": "[mass]",
    "A": "[current]",
    "K": "[temperature]",
    "m/s": "[velocity]",
    "m/s^2": "[acceleration]",
    "Pa": "[pressure]",
    "N": "[force]",
    "V": "[voltage]",
    "count": "dimensionless",
}


#: ``HMID_UNIT_CACHE``: a folder where pint keeps its parsed unit definitions (hmid's command
#: line sets it beside JAX's compilation cache; a spawned worker inherits it)
UNIT_CACHE_VARIABLE = "HMID_UNIT_CACHE"


@cache
def unit_registry() -> pint.UnitRegistry:
    """The one pint registry hmid uses, created on first use: ~0.4 s to parse pint's
    definitions, ~0.08 s to load them from the folder ``HMID_UNIT_CACHE`` names."""
    import pint

    folder = os.environ.get(UNIT_CACHE_VARIABLE)
    if not folder:
        return pint.UnitRegistry()

    try:
        os.makedirs(folder, exist_ok=True)
        lock = FileLock(os.path.join(folder, ".lock"))
        # pint writes its cache files in place: one process at a time, so none reads a
        # half-written file (a sweep starts several at once)
        with lock:
            try:
                return pint.UnitRegistry(cache_folder=folder)
            except Exception:  # a damaged file (pint's errors vary): the next process rewrites it
                for kept in Path(folder).glob("*.pickle"):
                    kept.unlink(missing_ok=True)
    except OSError:  # a folder that cannot be written: a cache only saves time
        pass
    return pint.UnitRegistry()


def parse_unit(unit: str) -> pint.Unit | None:
    """The pint unit for ``unit``, or None if pint cannot read it."""
    if not isinstance(unit, str) or not unit.strip():
        return None
    try:
        return unit_registry().parse_units(unit.strip())
    # pint's expression parser raises many unrelated types on malformed text (TokenError,
    # AssertionError, ZeroDivisionError, ...); every one of them means "not a unit".
    except Exception:
        return None


def _reference(unit: str) -> pint.Unit:
    """The pint unit of one of hmid's own reference units (always readable)."""
    parsed = parse_unit(unit)
    assert parsed is not None, unit
    return parsed


def dimension_name(unit: pint.Unit) -> str:
    """A readable name of the unit's dimension, e.g. '[pressure]'."""
    for reference, name in _DIMENSION_NAMES.items():
        if unit.dimensionality == _reference(reference).dimensionality:
            return name
    return str(unit.dimensionality)


@lru_cache(maxsize=256)
def si_unit(unit: str, channel: str) -> str:
    """The SI unit that ``unit`` converts to for ``channel``.

    Raises :class:`UnitError` (message without a file prefix) if pint does not know ``unit`` or,
    for a canonical channel, if its dimension is not the channel's.
    """
    parsed = parse_unit(unit)
    examples = EXAMPLES.get(channel, _OTHER_EXAMPLES)
    if parsed is None:
        raise UnitError(f"unknown unit {unit!r}; write a unit such as {examples}")
    if channel in CANONICAL_UNITS:
        target = CANONICAL_UNITS[channel]
        wanted = _reference(target)
        if parsed.dimensionality != wanted.dimensionality:
            kind = dimension_name(parsed)
            kind = kind if kind == "dimensionless" else f"a {kind}"
            raise UnitError(
                f"unit {unit!r} is {kind}, channel {channel} needs a "
                f"{dimension_name(wanted)} unit such as {examples}"
            )
        return target
    for name in _NAMED_SI:
        if parsed.dimensionality == _reference(name).dimensionality:
            return name
    base = unit_registry().Quantity(1.0, parsed).to_base_units().units
    # 'count' is its own (dimensionless) base unit in pint; '' would mean plain dimensionless.
    return f"{base:~C}" or "1"


def to_si(
    values: np.ndarray, unit: str, channel: str, source: str, *, column: str | int | None = None
) -> tuple[np.ndarray, str]:
    """``values`` in ``unit`` converted to SI for ``channel``: (float64 array, SI unit string).

    Raises :class:`UnitError` naming ``source``, the column and the channel if the unit is unknown
    or has the wrong dimension for a canonical channel.
    """
    try:
        target = si_unit(unit, channel)
    except UnitError as err:
        place = f"channel {channel}" if column is None else f"column {column!r} (channel {channel})"
        raise UnitError(f"{source}: {place}: {err}") from None
    ureg = unit_registry()
    quantity = ureg.Quantity(np.asarray(values, dtype="float64"), parse_unit(unit))
    converted = quantity.to(parse_unit(target) if target != "1" else ureg.dimensionless)
    return np.asarray(converted.magnitude, dtype="float64"), target


_SUPERSCRIPTS = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def format_unit(unit: pint.Unit) -> str:
    """A pint unit as compact text: 'N', 'N/m', 'N·s²/m²', 'N/(m·Pa)'; '1' if dimensionless."""
    ureg = unit_registry()

    def factor(name: str, power: float) -> str:
        symbol = ureg.get_symbol(name)
        power = abs(power)
        if power == 1:
            return symbol
        text = str(int(power)) if float(power).is_integer() else f"^{power:g}"
        return symbol + text.translate(_SUPERSCRIPTS)

    # pint's UnitsContainer: {'newton': 1, 'meter': -2, ...}; pint types an exponent as any
    # number (complex included), a unit's are int or float
    items: list[tuple[str, float]] = list(unit._units.items())  # type: ignore[arg-type]
    numerator = "·".join(factor(n, p) for n, p in items if p > 0) or "1"
    negative = [factor(n, p) for n, p in items if p < 0]
    if not negative:
        return numerator
    denominator = negative[0] if len(negative) == 1 else "(" + "·".join(negative) + ")"
    return f"{numerator}/{denominator}"
