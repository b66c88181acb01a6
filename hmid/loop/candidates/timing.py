"""Effects in time: a lag of the measured pressure, slow drift of stiffness or of the force zero."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from hmid.balance import Signals, raw
from hmid.balance.operations import lagged
from hmid.loop.candidates._base import Candidate, hyper, stack

_DRIFT_TIMES = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 1000.0)
#: The column the loop puts the fitted model's elastic force in (for stiffness drift).
ELASTIC = "fit:elastic"


class PressureLag(Candidate):
    name: ClassVar[str] = "pressure_lag"
    requires: ClassVar[tuple[str, ...]] = ("P",)
    title: ClassVar[str] = "pressure measured late"
    physics: ClassVar[str] = (
        "the pressure that acts leads the measured one by a delay d (sensor tubing, filtering, "
        "sensor far from the actuator): the model is given P(t + d) instead of P(t)"
    )

    @property
    def hyper(self):
        grid = np.round(np.arange(0.0, 0.1001, 0.0025), 4)
        return hyper("d", "s", grid, (False, False), log=False)

    @property
    def margins(self):
        return (0.0, 0.1)  # past a segment's end the lead is unknown: never fitted there

    def transform(self, signals: Signals, value):
        if not value:
            return signals
        return signals.with_columns(
            P=lagged(signals, signals["P"], -value, "delay"),
            **{raw("P"): lagged(signals, signals[raw("P")], -value, "delay")},
        )

    def columns(self, signals, value):
        return stack(signals)


def _drift(signals: Signals, tau: float) -> np.ndarray:
    """1 - exp(-t/T), scaled to 1 at the longest segment's last time: its coefficient is the
    change over that span whatever T, so a long T is a straight-line drift, not a huge number."""
    t = signals["t"]
    return np.expm1(-t / tau) / np.expm1(-t.max() / tau)


class StiffnessDrift(Candidate):
    name: ClassVar[str] = "stiffness_drift"
    elastic: ClassVar[bool] = True
    title: ClassVar[str] = "stiffness drift"
    physics: ClassVar[str] = (
        "the elastic force changes slowly over a test, (1 - f g(t)) x elastic force with "
        "g = (1 - exp(-t/T)) scaled to 1 at the end of the longest log: the latex warms up or "
        "its network relaxes (f > 0: softening by the fraction f over the test)"
    )

    @property
    def hyper(self):
        return hyper("T", "s", _DRIFT_TIMES)

    def columns(self, signals, value):
        # the elastic force enters the balance with its sign: softening takes a share f of it
        values = -_drift(signals, value) * signals[ELASTIC]
        return stack(signals, self.column(signals, "f", values, unit="1"))


class ForceZeroDrift(Candidate):
    name: ClassVar[str] = "force_zero_drift"
    title: ClassVar[str] = "force sensor zero drift"
    physics: ClassVar[str] = (
        "the force channel's zero moves slowly over a test (temperature, creep of the strain "
        "gauge): reading = force + D g(t), g as for stiffness drift, D the drift over the test"
    )

    @property
    def hyper(self):
        return hyper("T", "s", _DRIFT_TIMES)

    def columns(self, signals, value):
        return stack(signals, self.column(signals, "D", _drift(signals, value)))
