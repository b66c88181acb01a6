"""Reference trajectories the controllers track: steps both ways, a sine, a gait-like cycle.

Every reference is twice differentiable, its derivatives exact: inverse dynamics needs the
demanded velocity and acceleration, and no actuator follows a jump. A "step" is therefore a
minimum-jerk transition (quintic, zero velocity and acceleration at both ends) over a short
``transition``; the settling time is counted from the transition's end. The gait-like cycle is
a smooth periodic shape of four harmonics with a slow stance and a fast push-off, scaled to
[low, high]: what an ankle's muscle sees when walking, in the tracked quantity's own units (so
an ankle rig reuses it in radians).

A reference may start with a **hold** (a pre-roll): the start's value held for ``hold`` seconds
before the trajectory, the controller engaged, as a real experiment holds its initial set-point
(thesis Ch. 6: "each test starts in full plantarflexion") before it starts. The rig starts at
rest at the pressure the model says holds the start; a plant unlike the model (a fibre off its
type's model by the build's scatter) rests elsewhere, and the hold is where the loop pulls it to
the start. Only what follows the hold is scored (:meth:`Reference.scored`): a controller is
judged on tracking, not on where an unknown plant happened to rest before it was switched on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

ReferenceKind = Literal["step_up", "step_down", "sine", "gait"]
REFERENCE_KINDS: tuple[ReferenceKind, ...] = ("step_up", "step_down", "sine", "gait")

#: The gait-like shape: (harmonic, sine amplitude, cosine amplitude), normalised after summing
_GAIT = ((1, 1.0, 0.35), (2, 0.45, -0.25), (3, -0.2, 0.12), (4, 0.08, 0.06))


@dataclass(frozen=True)
class Reference:
    """A demanded trajectory at the sample instants ``t``: value, rate and second derivative.

    ``settle_from`` is where a step's transition ends (NaN where the task has no step) and
    ``size`` its height (the settling band's scale)."""

    kind: ReferenceKind
    t: np.ndarray
    y: np.ndarray
    dy: np.ndarray
    ddy: np.ndarray
    settle_from: float = float("nan")
    size: float = float("nan")
    hold: float = 0.0  # s of the start held before the trajectory (not scored)

    def scored(self) -> Reference:
        """The reference after its hold, its time from the hold's end (itself without one);
        on a uniform grid the clock's first instants, so a held run's time axis is exactly a
        run's without a hold."""
        if self.hold == 0:
            return self
        keep = self.t >= self.hold - 1e-9
        t = self.t[: np.count_nonzero(keep)] - self.t[0]
        return Reference(self.kind, t, self.y[keep], self.dy[keep], self.ddy[keep],
                         self.settle_from - self.hold, self.size)  # fmt: skip


def _quintic(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = np.clip(s, 0.0, 1.0)
    return (
        10 * s**3 - 15 * s**4 + 6 * s**5,
        30 * s**2 - 60 * s**3 + 30 * s**4,
        (60 * s - 180 * s**2 + 120 * s**3),
    )


def reference(
    kind: ReferenceKind,
    t: np.ndarray,
    low: float,
    high: float,
    *,
    step_at: float = 1.0,
    transition: float = 0.25,
    frequency: float = 1.0,
    hold: float = 0.0,
) -> Reference:
    """The reference ``kind`` between ``low`` and ``high`` at the times ``t`` (s): a step up
    (low to high at ``step_at``), down (high to low), a sine or the gait-like cycle at
    ``frequency`` (Hz), each starting at rest where it starts (a sine and a cycle fade in over
    their first period, so the demanded motion starts from rest), after ``hold`` s of its start
    held (the module's docstring; ``step_at`` counts from the hold's end)."""
    clock = np.asarray(t, dtype=float)
    t = np.maximum(clock - hold, 0.0)  # the trajectory's own time: 0 through the hold
    if kind in ("step_up", "step_down"):
        y0, y1 = (low, high) if kind == "step_up" else (high, low)
        s, ds, dds = _quintic((t - step_at) / transition)
        inside = (t > step_at) & (t < step_at + transition)
        span = y1 - y0
        return Reference(kind, clock, y0 + span * s,
                         np.where(inside, span * ds / transition, 0.0),
                         np.where(inside, span * dds / transition**2, 0.0),
                         hold + step_at + transition, abs(span), hold)  # fmt: skip
    w = 2 * np.pi * frequency
    if kind == "sine":
        shape, dshape, ddshape = -np.cos(w * t), w * np.sin(w * t), w**2 * np.cos(w * t)
    elif kind == "gait":
        shape, dshape, ddshape = _gait(w, t)
    else:
        raise ValueError(f"reference kind {kind!r} is not one of {REFERENCE_KINDS}")
    # fade in over one period: a quintic envelope times the shape about its start
    env, denv, ddenv = _quintic(t * frequency)
    denv, ddenv = denv * frequency, ddenv * frequency**2
    start = shape[0]
    g = start + env * (shape - start)
    dg = denv * (shape - start) + env * dshape
    ddg = ddenv * (shape - start) + 2 * denv * dshape + env * ddshape
    mid, half = (low + high) / 2, (high - low) / 2  # the shapes span [-1, 1] from -1
    return Reference(kind, clock, mid + half * g, half * dg, half * ddg, hold=hold)


def _gait(w: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    grid = np.linspace(0, 1, 2001, endpoint=False)

    def parts(phase):
        y = sum(a * np.sin(k * phase) + b * np.cos(k * phase) for k, a, b in _GAIT)
        dy = sum(k * (a * np.cos(k * phase) - b * np.sin(k * phase)) for k, a, b in _GAIT)
        ddy = sum(-(k**2) * (a * np.sin(k * phase) + b * np.cos(k * phase)) for k, a, b in _GAIT)
        return y, dy, ddy

    values = parts(2 * np.pi * grid)[0]
    lo, hi = values.min(), values.max()
    phase0 = 2 * np.pi * grid[np.argmin(values)]  # start at the minimum, as the sine does
    scale = 2 / (hi - lo)
    y, dy, ddy = parts(w * t + phase0)
    return (y - lo) * scale - 1, dy * w * scale, ddy * w**2 * scale
