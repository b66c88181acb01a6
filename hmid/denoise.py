"""Denoising stage: smoothed channels and estimated velocity and acceleration, as new channels.

A log may first be split where its logger paused (``split_gaps``), so that no filter runs across
a gap; pieces too short for the filters are left out and listed, never dropped silently.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from hmid.errors import LogError, SignalError
from hmid.io.log import Log
from hmid.io.plausibility import unit_factor
from hmid.io.segments import split_at_gaps
from hmid.signal import Differentiator, Smoother, estimate_motion

#: Derived channels: the differentiator's estimates, and those through the smoother too.
DERIVED_COLUMNS = ("v", "a_est", "v_s", "a_s")


def denoise_log(
    log: Log,
    smoother: Smoother,
    differentiator: Differentiator,
    *,
    channels: Iterable[str] | None = None,
    position: str | None = "x",
) -> Log:
    """A copy of ``log`` with ``<c>_s`` (smoothed) for each of ``channels`` (default: every
    channel), and from ``position``: ``v`` and ``a_est`` (the differentiator's estimates) and
    ``v_s``, ``a_s`` (those through the smoother as well, like every other signal a model reads,
    unless the differentiator already differentiates the smoothed position). A log too short for
    the windows is a :class:`LogError` naming it.
    """
    t = log.t
    names = log.channels if channels is None else tuple(channels)
    out, units = {}, {}
    step, section, kind = "smoothing", "denoise.smoother", smoother.kind
    try:
        for c in names:
            if c in log:
                out[f"{c}_s"], units[f"{c}_s"] = smoother(t, log[c]), log.units[c]
        if position is not None and position in log:
            step, section, kind = "differentiating", "denoise.derivative", differentiator.kind
            v, a = estimate_motion(t, log[position], differentiator)
            unit = log.units[position]
            smoothed = differentiator.includes(smoother)
            v_s, a_s = (v, a) if smoothed else (smoother(t, v), smoother(t, a))
            out |= {"v": v, "a_est": a, "v_s": v_s, "a_s": a_s}
            units |= {"v": f"{unit}/s", "a_est": f"{unit}/s^2", "v_s": f"{unit}/s",
                      "a_s": f"{unit}/s^2"}  # fmt: skip
    except SignalError as err:  # it says its own fix (a longer or a shorter window, ...)
        raise LogError(f"{log.source}: {step} failed: {err} ({section}, kind {kind!r})") from None
    return log.with_channels(units=units, **out)


@dataclass(frozen=True)
class Piece:
    """A contiguous piece of a log (the whole log unless it was split at a pause)."""

    log: str
    start_s: float
    duration_s: float
    samples: int
    used: bool  # long enough for the filters


def pieces(log: Log, name: str, split_gaps_s: float | None, min_duration_s: float):
    """``(pieces long enough for the filters, a Piece record of every piece)``."""
    parts = [log] if split_gaps_s is None else split_at_gaps(log, split_gaps_s)
    kept, records = [], []
    for part in parts:
        usable = part.duration >= min_duration_s
        records.append(Piece(name, float(part.t[0]), part.duration, len(part), usable))
        if usable:
            kept.append(part)
    if not kept and len(parts) == 1:  # no pause: the log itself is short
        raise LogError(
            f"{log.source}: the log holds only {len(log)} sample(s) over {log.duration:.4g} s, "
            f"shorter than the {min_duration_s:g} s (three filter windows) the smoothing and "
            "derivatives need; record a longer log or shorten denoise.smoother.window_s"
        )
    if not kept:
        raise LogError(
            f"{log.source}: no piece between logger pauses lasts {min_duration_s:g} s, three "
            "filter windows; shorten the windows or raise denoise.split_gaps_s"
        )
    return kept, records


def check_time_base(log: Log, window_s: float, time_unit: str) -> None:
    """LogError if the log's time step is over twice the smoothing window: the window would hold
    less than a sample. Almost always a time unit off by 1000 (a 1 kHz log in ms read
    as s, 1 Hz), so the time unit is named before the window."""
    if len(log) < 2:
        return
    step = 1.0 / log.sample_rate
    if window_s >= step / 2:  # the moving average's own limit: a window of one sample
        return

    better = [
        unit
        for unit in ("ms", "us", "s")
        if unit != time_unit and step * unit_factor(unit) / unit_factor(time_unit) <= window_s / 2
    ]
    hint = (
        f"is the time column in {better[0]} rather than {time_unit} (the log would be sampled at "
        f"{log.sample_rate * unit_factor(time_unit) / unit_factor(better[0]):.4g} Hz)? Set "
        "channels.t.unit in the column map; if the rig really samples this slowly, lengthen "
        "denoise.smoother.window_s"
        if better
        else "lengthen denoise.smoother.window_s to a few time steps"
    )
    raise LogError(
        f"{log.source}: sampled every {step:.4g} s ({log.sample_rate:.4g} Hz), longer than the "
        f"{window_s:g} s smoothing window: {hint}"
    )
