"""Velocity for the SINDy family from pysindy's differentiation, as an alternative to hmid's own.

``SmoothedFiniteDifference`` (a Savitzky-Golay smoother then centred differences) runs on each
whole log, so its edges are the log's edges, not the training rows'. Methods that solve dense
systems over the whole record (pysindy's ``kalman`` / ``trend_filtered`` through the
``derivative`` package) need memory quadratic in the log length and are not offered.
"""

from __future__ import annotations

import numpy as np
import pysindy as ps

from hmid.errors import ConfigError


def smoothed_velocity(t: np.ndarray, x: np.ndarray, window_s: float, polyorder: int) -> np.ndarray:
    """dx/dt by pysindy's SmoothedFiniteDifference with a ``window_s`` Savitzky-Golay window."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if not dt > 0:
        raise ConfigError("velocity: the log's time column must increase")
    window = round(window_s / dt) | 1  # odd number of samples
    if window <= polyorder or window > len(t):
        raise ConfigError(
            f"velocity.window_s={window_s} gives {window} samples: it must exceed "
            f"polyorder={polyorder} and fit in the log ({len(t)} samples)"
        )
    # a fresh dict: pysindy's default smoother_kws is a shared mutable default it writes into
    method = ps.SmoothedFiniteDifference(
        smoother_kws={"window_length": window, "polyorder": polyorder}
    )
    return np.asarray(method(x.reshape(-1, 1), t), dtype=float).reshape(-1)


class SmoothedVelocity:
    """A picklable ``(t, x) -> v`` with fixed smoothing settings (see :func:`smoothed_velocity`)."""

    def __init__(self, window_s: float, polyorder: int) -> None:
        self.window_s = float(window_s)
        self.polyorder = int(polyorder)

    def __call__(self, t: np.ndarray, x: np.ndarray) -> np.ndarray:
        return smoothed_velocity(t, x, self.window_s, self.polyorder)

    def __repr__(self) -> str:
        return f"SmoothedVelocity(window_s={self.window_s}, polyorder={self.polyorder})"
