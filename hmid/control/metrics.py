"""How well a controller tracked: RMSE, largest error, settling time, valve switchings.

The error is the tracked output as the rig logged it (the truth, not the sensor) less the
reference at the same instant. The settling time of a step counts from the end of its
transition (when the reference has arrived) to the last time the error leaves a band of 2 % of
the step, or two sensor steps if that is wider: a controller that never leaves the band settles
in 0 s, one that is still outside at the end never settles (infinity). The travel time of a
step counts from the reference's first move to the output's first arrival at 90 % of its own
travel (the thesis's travel by direction, Ch. 6; infinity if it never arrives). Switchings count the
on/off valves' operations (None for a proportional valve).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hmid.control.actuation import switchings
from hmid.control.references import Reference


@dataclass(frozen=True)
class Metrics:
    """One run's tracking scores (units of the tracked output; seconds)."""

    rmse: float
    max_error: float
    settling_s: float  # NaN where the reference has no step; inf if it never settles
    switchings: int | None
    travel_s: float = float("nan")  # to 90 % of a step; NaN where the reference has none


def travel_time(ref: Reference, t: np.ndarray, y: np.ndarray, fraction: float = 0.9) -> float:
    """Seconds from a step reference's first move to the output's first arrival at
    ``fraction`` of its own travel, from where it started to where it ends (the median of the
    run's last tenth: a PD that stops short of the target still travels, and a valve's limit
    cycle is averaged); NaN without a step, infinity if it never arrives."""
    if not np.isfinite(ref.settle_from):
        return float("nan")
    moved = np.flatnonzero(ref.y != ref.y[0])
    start = float(ref.t[max(int(moved[0]) - 1, 0)])
    end = float(np.median(y[-max(len(y) // 10, 1) :]))
    progress = (y - y[0]) / (end - y[0])
    arrived = np.flatnonzero((t >= start) & (progress >= fraction))
    return float(t[arrived[0]] - start) if arrived.size else float("inf")


def tracking_score(
    ref: Reference, t: np.ndarray, y: np.ndarray, resolution: float, valve: np.ndarray | None
) -> Metrics:
    """Scores of the output ``y`` at the times ``t`` (instants of the reference's grid)."""
    error = y - np.interp(t, ref.t, ref.y)
    settling = float("nan")
    if np.isfinite(ref.settle_from):
        band = max(0.02 * ref.size, 2 * resolution)
        after = t >= ref.settle_from
        outside = np.flatnonzero(after & (np.abs(error) > band))
        if outside.size == 0:
            settling = 0.0
        elif outside[-1] == len(t) - 1:
            settling = float("inf")
        else:
            settling = float(t[outside[-1] + 1] - ref.settle_from)
    return Metrics(
        rmse=float(np.sqrt(np.mean(error**2))),
        max_error=float(np.max(np.abs(error))),
        settling_s=settling,
        switchings=None if valve is None else switchings(valve),
        travel_s=travel_time(ref, t, y),
    )
