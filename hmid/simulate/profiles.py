"""Commanded pressure profiles for dynamic-loading tests (the valve then shapes the real pressure).

Each profile is a frozen config with a ``kind`` tag and a ``command(t, rng)`` method returning the
commanded gauge pressure in Pa at times ``t``. Randomised profiles draw only from the generator
they are given, so a log is reproducible from its seed.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.signal import chirp as _chirp

from hmid.config import Positive

Pressure = Annotated[float, Field(ge=0, le=5e6)]


class _Profile(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    def command(self, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError


class Cycles(_Profile):
    """Repeated extension/relaxation: trapezoidal cycles between ``low`` and ``high``."""

    kind: Literal["cycles"] = "cycles"
    low: Pressure = 3.0e4
    high: Pressure = 2.5e5
    period: Positive = 2.0  # s
    duty: Annotated[float, Field(gt=0, lt=1)] = 0.5  # fraction of the period at high
    ramp: Annotated[float, Field(ge=0)] = 0.2  # s, commanded ramp on each edge

    @model_validator(mode="after")
    def _fits_in_period(self) -> Cycles:
        if 2 * self.ramp + self.duty * self.period > self.period:
            raise ValueError("2 ramp + duty period must not exceed the period")
        return self

    def command(self, t, rng):
        phase = np.mod(t, self.period)
        up, hold = self.ramp, self.duty * self.period
        frac = np.clip(phase / up, 0, 1) if up > 0 else np.ones_like(phase)
        down = np.clip((phase - up - hold) / up, 0, 1) if up > 0 else (phase >= up + hold) * 1.0
        return self.low + (self.high - self.low) * (frac - down)


class Steps(_Profile):
    """A staircase up through ``levels`` and back down, each held for ``hold`` seconds."""

    kind: Literal["steps"] = "steps"
    levels: Annotated[tuple[Pressure, ...], Field(min_length=1)] = (
        3.0e4, 8.0e4, 1.3e5, 1.8e5, 2.3e5,
    )  # fmt: skip
    hold: Positive = 1.5

    def command(self, t, rng):
        sequence = np.asarray(self.levels + self.levels[-2::-1])
        index = (t // self.hold).astype(int) % len(sequence)
        return sequence[index]


class _Oscillating(_Profile):
    """A wave around ``offset``; the gauge pressure must stay >= 0."""

    offset: Pressure = 1.4e5
    amplitude: Pressure = 1.0e5

    @model_validator(mode="after")
    def _non_negative(self):
        if self.amplitude > self.offset:
            raise ValueError("amplitude must not exceed offset (gauge pressure stays >= 0)")
        return self


class Sine(_Oscillating):
    """``offset + amplitude sin(2 pi f t)``; close to the thesis's dynamic loading."""

    kind: Literal["sine"] = "sine"
    frequency: Positive = 0.5  # Hz

    def command(self, t, rng):
        return self.offset + self.amplitude * np.sin(2 * np.pi * self.frequency * t)


class Chirp(_Oscillating):
    """Sinusoid sweeping from ``f0`` to ``f1`` over the log (scipy.signal.chirp)."""

    kind: Literal["chirp"] = "chirp"
    amplitude: Pressure = 8.0e4
    f0: Positive = 0.1
    f1: Positive = 3.0
    method: Literal["linear", "logarithmic"] = "logarithmic"

    def command(self, t, rng):
        t1 = float(t[-1]) if len(t) and t[-1] > 0 else 1.0
        wave = _chirp(t, f0=self.f0, t1=t1, f1=self.f1, method=self.method, phi=-90)
        return self.offset + self.amplitude * wave


class RandomLevels(_Profile):
    """Random multi-level sequence: uniform levels in [low, high], random hold times."""

    kind: Literal["random_levels"] = "random_levels"
    low: Pressure = 3.0e4
    high: Pressure = 2.5e5
    hold_min: Positive = 0.3
    hold_max: Positive = 1.5

    @model_validator(mode="after")
    def _order(self) -> RandomLevels:
        if self.high < self.low or self.hold_max < self.hold_min:
            raise ValueError("need low <= high and hold_min <= hold_max")
        return self

    def command(self, t, rng):
        span = float(t[-1] - t[0]) if len(t) else 0.0
        n = int(np.ceil(span / self.hold_min)) + 2
        holds = rng.uniform(self.hold_min, self.hold_max, size=n)
        levels = rng.uniform(self.low, self.high, size=n)
        edges = t[0] + np.concatenate([[0.0], np.cumsum(holds)])
        index = np.searchsorted(edges, t, side="right") - 1
        return levels[np.clip(index, 0, n - 1)]


class Constant(_Profile):
    """A constant command (e.g. zero for free-fall tests)."""

    kind: Literal["constant"] = "constant"
    value: Pressure = 0.0

    def command(self, t, rng):
        return np.full_like(t, self.value, dtype=float)


Profile = Annotated[
    Cycles | Steps | Sine | Chirp | RandomLevels | Constant, Field(discriminator="kind")
]
