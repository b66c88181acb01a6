"""A channel measured late: a pure delay (transport, a slow bus, a sample-and-hold) or a
first-order lag (a filter, pneumatic tubing), on the position or on any input channel.

Each transforms the channel every term reads (a late position also makes its velocity and
acceleration late). A sample-and-hold of period h acts, through the smoother, as a delay of h/2;
its steps are not offered as their own effect. A delay and a lag shift the phase alike at low
frequency and differ only in how they attenuate: the loop tells them apart only when the motion's
bandwidth allows, and otherwise reports them as one timing effect of that channel.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import ClassVar

import numpy as np

from hmid.balance import Signals, raw
from hmid.balance.operations import declare_sum, lagged
from hmid.loop.candidates._base import Candidate, Setting, hyper, stack

DELAYS = tuple(np.round(np.arange(0.0, 0.1001, 0.0025), 4))


def delays(dt: float | None) -> tuple[float, ...]:
    """The delay grid: :data:`DELAYS`, in steps of one sample period where the logs are sampled
    faster than its 2.5 ms (a 0.6 ms delay at 1 kHz needs grid values that bracket it)."""
    step = DELAYS[1]
    if dt is None or not 0 < dt < step:
        return DELAYS
    step = float(np.round(dt, 6))
    return tuple(np.round(np.arange(0.0, DELAYS[-1] + step / 2, step), 6))


LAGS = tuple(np.round(np.geomspace(0.001, 0.2, 24), 5))


class _Timing(Candidate):
    """Timing of ``channel``: its transform changes the channel (and its derivatives)."""

    word: ClassVar[str] = ""
    title_text: ClassVar[str] = ""  # "{c}" is the channel
    physics_text: ClassVar[str] = ""

    def __init__(self, setting: Setting, channel: str) -> None:
        super().__init__(setting)
        self.channel = channel
        self.name = f"{self.word}.{channel}"
        self.requires = (channel,)
        self.title = self.title_text.format(c=channel)
        self.physics = self.physics_text.format(c=channel)

    @property
    def follows(self) -> str:
        return f"the rate of change of {self.channel}"

    @classmethod
    def variants(cls, setting: Setting) -> Iterator[Candidate]:
        for channel in (setting.position, *setting.inputs):
            if channel is not None:
                yield cls(setting, channel)

    @property
    def _chain(self) -> tuple[str, ...]:
        """The channel and what is derived from it."""
        if self.channel == self.setting.position:
            return (self.channel, "v", "a")
        return (self.channel,)

    def columns(self, signals, value):
        return stack(signals)  # it only changes what the other terms see

    def transform(self, signals: Signals, value):
        if not value:
            return signals
        changed = {}
        for c in self._chain:
            for name in (c, raw(c)):
                if name in signals:
                    changed[name] = self._undo(signals, name, value)
        return self._declared(signals, signals.with_columns(**changed), value)

    def _undo(self, signals: Signals, name: str, value: float) -> np.ndarray:
        raise NotImplementedError

    def _declared(self, signals: Signals, seen: Signals, value: float) -> Signals:
        """``seen``, with what is known of how its channels follow from ``signals``'."""
        return seen


class Delay(_Timing):
    kind: ClassVar[str] = "delay"
    word: ClassVar[str] = "delay"
    title_text: ClassVar[str] = "{c} measured late"
    physics_text: ClassVar[str] = (
        "the {c} that acts leads the logged one by a delay d (transport, a slow bus or camera, "
        "a sample-and-hold of period 2d): the model is given {c}(t + d)"
    )

    @property
    def hyper(self):
        return hyper("d", "s", delays(self.setting.dt), (False, False), log=False)

    @property
    def margins(self):
        return (0.0, DELAYS[-1])  # past a segment's end the lead is unknown: never fitted there

    def _undo(self, signals, name, value):
        return lagged(signals, signals[name], -value, "delay")


class Lag(_Timing):
    kind: ClassVar[str] = "lag"
    word: ClassVar[str] = "lag"
    title_text: ClassVar[str] = "{c} measured through a lag"
    physics_text: ClassVar[str] = (
        "the logged {c} follows the true one through a first-order lag of time constant T (a "
        "filter, tubing, a thermal sensor): the model is given {c} + T d{c}/dt"
    )

    @property
    def hyper(self):
        return hyper("T", "s", LAGS, (False, False))

    @property
    def margins(self):
        return (0.0, 0.0)

    def _undo(self, signals, name, value):
        # the inverse of T y' + y = u is u = y + T y', with y' of the smoothed channel (a raw
        # channel's own derivative would be its noise amplified)
        smooth = name.removeprefix("raw:")
        return signals[name] + value * self._slopes(signals, smooth)[slope_name(smooth)]

    def _declared(self, signals, seen, value):
        for c in self._chain:
            if c in signals:
                slopes = self._slopes(signals, c)
                declare_sum(seen, c, ((1.0, signals, c), (value, slopes, slope_name(c))))
        return seen

    @staticmethod
    def _slopes(signals: Signals, channel: str) -> Signals:
        """``signals`` with d(channel)/dt per segment as a column: the same for every time
        constant, so found once (and the slope's memory arms with it)."""

        def compute() -> Signals:
            slope = np.empty(len(signals))
            t, y = signals["t"], signals[channel]
            for rows in signals.segments():
                slope[rows] = np.gradient(y[rows], t[rows]) if len(rows) > 1 else 0.0
            return signals.with_columns(**{slope_name(channel): slope})

        return signals.derived(("slopes", channel), compute)


def slope_name(channel: str) -> str:
    """The column of ``channel``'s slope in :meth:`Lag._slopes`' signals."""
    return f"d/dt:{channel}"
