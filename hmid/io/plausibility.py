"""Plausibility from physics: is what a log says possible on the rig that recorded it?

A log can pass every format check (numbers, increasing time, a known unit) and still be wrong by
a unit or a wiring: a time column in seconds mapped as milliseconds, a position in millimetres
mapped as metres, two columns swapped, a sensor stuck or clipping. The fit then explains the
wrong data very well. The checks here judge each channel against what its unit, the sample rate
and the rig make possible (speeds and accelerations the position implies, the span a sensor
covers, the range the rig declares) and return :class:`DataFinding` s: pure functions, no I/O, no
warnings. The pipeline says them on the console and in the report, and ``hmid run --strict``
makes them errors. A finding that no result can survive (a sample of 1e300) is ``fatal``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Literal

import numpy as np

Kind = Literal[
    "time_unit", "unit", "speed", "range", "stuck", "clipped", "outlier", "swapped", "no_rows"
]

#: A rig that declares no limits: faster than 10 m/s or 1000 m/s² (about 100 g) no soft
#: actuator rig moves; the shipped demo logs peak at 1.2 m/s and 22 m/s².
MAX_SPEED = 10.0
MAX_ACCELERATION = 1000.0
#: A sample farther than this many times the central 99.8 % span from it is an outlier; farther
#: than FATAL_OUTLIER times, no result can be trusted (squares overflow, fits break).
OUTLIER = 10.0
FATAL_OUTLIER = 1e6
#: A channel covering less than this share of its declared range is likely in another unit.
SPAN_SHARE = 0.01
#: Clipping: at least this share of samples (and CLIP_SAMPLES) sit on the extreme value, CLIP_SPIKE
#: times as many as just inside it.
CLIP_SHARE = 0.005
CLIP_SAMPLES = 10
CLIP_SPIKE = 5.0

_TIME_UNITS = ("s", "ms", "us")
_LENGTH_UNITS = ("m", "cm", "mm", "um")


@dataclass(frozen=True)
class DataFinding:
    """What is implausible in log ``log`` (channel ``channel``), said in ``text``."""

    log: str
    channel: str | None
    kind: Kind
    text: str
    fatal: bool = False

    def message(self) -> str:
        where = f"channel {self.channel}" if self.channel else "log"
        return f"data: {self.log}: {where}: {self.text}"

    def to_dict(self) -> dict:
        return asdict(self) | {"message": self.message()}


@dataclass(frozen=True)
class Limits:
    """What the rig can do (SI): the position's top speed and acceleration, each channel's
    plausible range."""

    max_speed: float = MAX_SPEED
    max_acceleration: float = MAX_ACCELERATION
    ranges: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def range(self, channel: str) -> tuple[float, float] | None:
        return self.ranges.get(channel)


def _g(value: float) -> str:
    return f"{value:.3g}"


def unit_factor(unit: str) -> float:
    """SI value of one ``unit`` (``mm`` -> 0.001)."""
    from hmid.io.units import unit_registry

    ureg = unit_registry()
    quantity = ureg.Quantity(1.0, ureg.parse_units(unit))
    return float(quantity.to_base_units().magnitude)


# -- one channel at a time ------------------------------------------------------------------------
def stuck(log: str, channel: str, values: np.ndarray, unit: str) -> DataFinding | None:
    """A channel that never changes: a stuck sensor, an unplugged input, a constant written in."""
    if len(values) < 2 or np.ptp(values) > 1e-12 * max(abs(float(values[0])), 1e-300):
        return None
    return DataFinding(
        log, channel, "stuck",
        f"constant ({_g(float(values[0]))} {unit}) over all {len(values)} samples: a stuck or "
        "unplugged sensor; nothing can be learnt from it",
    )  # fmt: skip


def _sample(values: np.ndarray) -> np.ndarray:
    """At most about a million of ``values``, evenly strided: quantiles of a long log without a
    sorted copy of it (the thresholds they set have a wide margin)."""
    return values[:: max(1, len(values) // 1_000_000)]


def outliers(log: str, channel: str, values: np.ndarray, unit: str) -> DataFinding | None:
    """Isolated samples far outside the span of all the others (``fatal`` when absurd)."""
    if len(values) < 20:
        return None
    low, high = (float(q) for q in np.percentile(_sample(values), [0.1, 99.9]))
    span = max(high - low, 1e-9 * max(abs(low), abs(high), 1e-300))
    far = np.flatnonzero((values < low - OUTLIER * span) | (values > high + OUTLIER * span))
    if not len(far):
        return None
    distance = np.maximum(low - values[far], values[far] - high) / span
    worst = int(far[np.argmax(distance)])
    fatal = bool(np.max(distance) > FATAL_OUTLIER)
    return DataFinding(
        log,
        channel,
        "outlier",
        f"{len(far)} isolated sample(s) far outside the others' span {_g(low)} … {_g(high)} "
        f"{unit}, worst {_g(float(values[worst]))} {unit} at row {worst + 1}: a glitch of the "
        "logger or a corrupted file; fix or remove those rows (hmid does not drop samples)",
        fatal,
    )


def clipped(log: str, channel: str, values: np.ndarray, unit: str) -> DataFinding | None:
    """Samples piled on the channel's extreme value: a sensor or amplifier clipping (inside the
    declared range, else the loader's saturation flag says it), not a signal resting there."""
    n = len(values)
    if n < 100 or np.ptp(values) == 0:
        return None
    low, high = float(np.min(values)), float(np.max(values))
    band = 0.01 * (high - low)
    for end, inside in ((high, values >= high - band), (low, values <= low + band)):
        at = int(np.count_nonzero(values == end))
        near = int(np.count_nonzero(inside)) - at
        if at >= max(CLIP_SAMPLES, CLIP_SHARE * n) and at >= CLIP_SPIKE * max(near, 1):
            return DataFinding(
                log, channel, "clipped",
                f"{at} samples ({100 * at / n:.1f} %) sit exactly at {_g(end)} {unit}, "
                f"{'the largest' if end == high else 'the smallest'} value, and only {near} "
                "just inside it: the sensor or its amplifier clips there; re-record within its "
                "range or leave those rows out",
            )  # fmt: skip
    return None


def out_of_range(
    log: str,
    channel: str,
    values: np.ndarray,
    unit: str,
    own_unit: str,
    bounds: tuple[float, float],
) -> DataFinding | None:
    """Samples outside the rig's declared ``range`` (SI), with the unit that would fit."""
    low, high = bounds
    outside = int(np.count_nonzero((values < low) | (values > high)))
    if not outside:
        return None
    hint = _unit_hint(own_unit, (float(np.min(values)), float(np.max(values))), bounds)
    return DataFinding(
        log, channel, "range",
        f"{outside} sample(s) outside the rig's range {_g(low)} … {_g(high)} {unit} (values "
        f"{_g(float(np.min(values)))} … {_g(float(np.max(values)))} {unit}){hint}",
    )  # fmt: skip


def small_span(
    log: str,
    channel: str,
    values: np.ndarray,
    unit: str,
    own_unit: str,
    bounds: tuple[float, float],
    what: str,
) -> DataFinding | None:
    """A channel that covers a tiny share of its declared range (SI): likely in another unit."""
    low, high = float(np.min(values)), float(np.max(values))
    width = bounds[1] - bounds[0]
    if high <= low or width <= 0 or (high - low) >= SPAN_SHARE * width:
        return None
    if low < bounds[0] or high > bounds[1]:
        return None
    hint = _unit_hint(own_unit, (low, high), bounds, fill=True)
    return DataFinding(
        log, channel, "unit",
        f"spans {_g(low)} … {_g(high)} {unit}, {100 * (high - low) / width:.2g} % of {what} "
        f"{_g(bounds[0])} … {_g(bounds[1])} {unit}{hint or ': check its unit and scale'}",
    )  # fmt: skip


def _unit_hint(
    unit: str, span: tuple[float, float], bounds: tuple[float, float], *, fill: bool = False
) -> str:
    """``": is it in mm rather than m?"`` when another unit of the same kind puts ``span``
    (SI, read in ``unit``) inside ``bounds`` (and, with ``fill``, over a tenth of them)."""
    from hmid.io.units import parse_unit

    parsed = parse_unit(unit)
    if parsed is None:
        return ""
    here = unit_factor(unit)
    candidates = {
        "[length]": _LENGTH_UNITS,
        "[mass] / [length] / [time] ** 2": ("Pa", "kPa", "bar", "MPa", "psi", "mbar"),
        "[length] * [mass] / [time] ** 2": ("N", "kN", "mN"),
        "[time]": _TIME_UNITS,
    }.get(str(parsed.dimensionality), ())
    width = bounds[1] - bounds[0]
    best, score = None, math.inf
    for other in candidates:
        if other == unit:
            continue
        scale = unit_factor(other) / here
        low, high = span[0] * scale, span[1] * scale
        if low < bounds[0] or high > bounds[1]:
            continue
        if fill and (high - low) < 0.1 * width:
            continue
        distance = abs(math.log10(scale))
        if distance < score:
            best, score = other, distance
    return f": is it in {best} rather than {unit}?" if best else ""


# -- the position's motion ----------------------------------------------------------------------
def motion(
    log: str,
    position: str,
    peak_speed: float,
    peak_acceleration: float,
    rate_hz: float,
    limits: Limits,
    time_unit: str,
    position_unit: str,
    plausible_rate: tuple[float, float] = (1.0, 100_000.0),
) -> DataFinding | None:
    """Speeds or accelerations the rig cannot reach, blamed on the unit that explains them: a
    time unit scales the speed by k and the acceleration by k², a position unit both by k; of
    the units that bring both within the limits, the one that leaves the motion's own rate
    (peak acceleration / peak speed) nearest a rig's is named first."""
    if not (peak_speed > limits.max_speed or peak_acceleration > limits.max_acceleration):
        return None
    found = (
        f"speeds of {_g(peak_speed)} m/s and accelerations of {_g(peak_acceleration)} m/s² "
        f"(log sampled at {_g(rate_hz)} Hz) exceed what the rig can do (max_speed "
        f"{_g(limits.max_speed)} m/s, max_acceleration {_g(limits.max_acceleration)} m/s²)"
    )
    # a time unit k scales the acceleration's excess k times more than the speed's
    time_first = math.log(peak_acceleration / limits.max_acceleration) > math.log(
        peak_speed / limits.max_speed
    ) + math.log(10.0)
    times, lengths = [], []
    for unit in _TIME_UNITS:
        k = unit_factor(unit) / unit_factor(time_unit)  # true time = k x read time
        new_rate = rate_hz / k
        if unit == time_unit or not plausible_rate[0] <= new_rate <= plausible_rate[1]:
            continue
        if (
            peak_speed / k <= limits.max_speed
            and peak_acceleration / k**2 <= limits.max_acceleration
        ):
            times.append(
                f"is the time column in {unit} rather than {time_unit} (the log would be "
                f"sampled at {_g(new_rate)} Hz)?"
            )
    for unit in ("mm", "m", "um", "cm"):  # the usual ones first
        k = unit_factor(unit) / unit_factor(position_unit)
        if unit == position_unit:
            continue
        if peak_speed * k <= limits.max_speed and peak_acceleration * k <= limits.max_acceleration:
            lengths.append(f"is {position} in {unit} rather than {position_unit}?")
    said = (times[:1] + lengths[:1]) if time_first else (lengths[:1] + times[:1])
    advice = (
        ": " + " Or ".join(said)
        if said
        else f": check the units of t and {position}, or declare rig.channels.{position}."
        "max_speed and max_acceleration"
    )
    if said and said[0].startswith("is the time"):
        return DataFinding(log, position, "time_unit", found + advice)
    return DataFinding(log, position, "speed", found + advice)


# -- between channels ---------------------------------------------------------------------------
def swapped(
    log: str,
    values: Mapping[str, np.ndarray],
    ranges: Mapping[str, tuple[float, float]],
    units: Mapping[str, str],
) -> tuple[DataFinding, ...]:
    """Two channels whose values each fit the other's declared range and not their own: their
    columns are swapped. ``values`` in SI, ``ranges`` in each channel's own unit (``units``):
    a column's numbers are compared as the file holds them."""
    names = [c for c in values if c in ranges]
    factor = {c: unit_factor(units[c]) for c in names}
    found = []

    def inside(channel: str, bounds: tuple[float, float]) -> float:
        v, low, high = values[channel], bounds[0] * factor[channel], bounds[1] * factor[channel]
        return float(np.count_nonzero((v >= low) & (v <= high))) / max(len(v), 1)

    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            own = min(inside(a, ranges[a]), inside(b, ranges[b]))
            crossed = min(inside(a, ranges[b]), inside(b, ranges[a]))
            if own < 0.99 and crossed >= 0.999:
                found.append(
                    DataFinding(
                        log,
                        f"{a}, {b}",
                        "swapped",
                        f"{a} and {b} look swapped: their values fit each other's declared "
                        f"range ({a} {_g(ranges[a][0])} … {_g(ranges[a][1])} {units[a]}, {b} "
                        f"{_g(ranges[b][0])} … {_g(ranges[b][1])} {units[b]}) better than "
                        "their own; check the columns the column map names",
                    )
                )
    return tuple(found)


# -- what the fit gets from each log ------------------------------------------------------------
def no_rows(
    log: str,
    rows: int,
    usable: int,
    peak_speed: float | None,
    v_deadband: float,
    position: str | None,
) -> DataFinding | None:
    """A dynamic log that contributes no row to the fit, and why."""
    if usable:
        return None
    if rows == 0:
        why = "every piece of it is too short for the smoothing and derivative windows"
    elif peak_speed is not None and peak_speed < v_deadband:
        why = (
            f"its speed never reaches fit.v_deadband {_g(v_deadband)} m/s (peak "
            f"{_g(peak_speed)} m/s), so every row counts as stopped: is {position} stuck, or "
            f"its unit too small (e.g. values in m mapped as mm)?"
        )
    else:
        why = (
            f"the motion stops too often (|v| < fit.v_deadband {_g(v_deadband)} m/s) for any "
            "row to lie clear of a stop by the smoother's reach"
        )
    return DataFinding(log, None, "no_rows", f"contributes no rows to the fit: {why}")


def check_channels(
    log: str,
    channels: Mapping[str, np.ndarray],
    units: Mapping[str, str],
    own_units: Mapping[str, str],
    sensor_ranges: Mapping[str, tuple[float, float]],
    limits: Limits,
) -> tuple[DataFinding, ...]:
    """Every single-channel and between-channel check of one log's channels (SI values;
    ``sensor_ranges`` are the column map's, SI)."""
    found: list[DataFinding | None] = []
    for name, values in channels.items():
        unit = units.get(name, "")
        one = stuck(log, name, values, unit)
        found.append(one)
        if one is not None:
            continue
        found += [outliers(log, name, values, unit), clipped(log, name, values, unit)]
        declared = limits.range(name)
        if declared is not None:
            found.append(out_of_range(log, name, values, unit, own_units.get(name, unit),
                                      declared))  # fmt: skip
        for bounds, what in ((declared, "the rig's range"),
                             (sensor_ranges.get(name), "its sensor's range")):  # fmt: skip
            if bounds is not None:
                span = small_span(log, name, values, unit, own_units.get(name, unit), bounds, what)
                if span is not None:
                    found.append(span)
                    break
    found += swapped(
        log,
        {c: v for c, v in channels.items() if c in sensor_ranges},
        {
            c: (r[0] / unit_factor(own_units[c]), r[1] / unit_factor(own_units[c]))
            for c, r in sensor_ranges.items()
        },
        own_units,
    )
    return tuple(f for f in found if f is not None)


def ordered(findings: Sequence[DataFinding]) -> tuple[DataFinding, ...]:
    """The findings, fatal first, each once."""
    unique = list(dict.fromkeys(findings))
    return tuple(sorted(unique, key=lambda f: not f.fatal))
