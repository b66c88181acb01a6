"""Slow change over a test: the elastic force softens, the muscle's rest length creeps, the force
sensor's zero moves. Each follows g(t) = 1 - exp(-t/T) scaled to 1 at the longest log's end (T
profiled), so its coefficient is the change over the test whatever T."""

from __future__ import annotations

from collections.abc import Iterator
from typing import ClassVar

import numpy as np

from hmid.balance import Signals
from hmid.loop.candidates._base import Candidate, Setting, hyper, stack

DRIFT_TIMES = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 1000.0)
#: Columns the loop fills from the fitted model: its elastic force (the terms that read the
#: position alone, at their coefficients) and that force's derivative in the position.
ELASTIC = "fit:elastic"
STIFFNESS = "fit:stiffness"


def drift(signals: Signals, tau: float) -> np.ndarray:
    """1 - exp(-t/T), scaled to 1 at the longest log's last time: a long T is a straight-line
    drift with a coefficient of the same size, not a huge number."""
    t = signals["t"]
    return np.expm1(-t / tau) / np.expm1(-t.max() / tau)


class _Drift(Candidate):
    @property
    def hyper(self):
        return hyper("T", "s", DRIFT_TIMES)

    @classmethod
    def variants(cls, setting: Setting) -> Iterator[Candidate]:
        if setting.position is not None or not cls.elastic:  # an elastic force needs a position
            yield cls(setting)


class StiffnessDrift(_Drift):
    kind: ClassVar[str] = "stiffness_drift"
    elastic: ClassVar[bool] = True
    name = "stiffness_drift"
    title = "stiffness drift"
    physics = (
        "the elastic force changes slowly over a test, (1 - f g(t)) x elastic force: the latex "
        "warms up or its network relaxes (f > 0: softening by the fraction f over the test)"
    )

    def columns(self, signals, value):
        # the elastic force enters the balance with its sign: softening takes a share f of it
        values = -drift(signals, value) * signals[ELASTIC]
        return stack(signals, self.column(signals, "f", values, unit="1"))


class PreloadDrift(_Drift):
    kind: ClassVar[str] = "preload_drift"
    elastic: ClassVar[bool] = True
    name = "preload_drift"
    title = "preload drift"
    physics = (
        "the elastic element's rest length creeps over a test (the muscle takes a set): the "
        "elastic force is that of x - s g(t), s the creep over the test. Where the stiffness "
        "hardly changes with x it is a force offset drifting, like a sensor's zero"
    )

    def columns(self, signals, value):
        values = -drift(signals, value) * signals[STIFFNESS]
        return stack(
            signals, self.column(signals, "s", values, unit=signals.unit(signals.position))
        )


class ZeroDrift(_Drift):
    kind: ClassVar[str] = "zero_drift"
    name = "zero_drift"
    title = "sensor zero drift"
    physics = (
        "the explained channel's zero moves slowly over a test (temperature, creep of a strain "
        "gauge): reading = force + D g(t), D the drift over the test"
    )

    def columns(self, signals, value):
        return stack(signals, self.column(signals, "D", drift(signals, value)))
