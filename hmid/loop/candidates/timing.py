"""Effects in time: a lag of the measured pressure, slow drift of stiffness or of the force zero."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from hmid.loop.candidates._base import Candidate
from hmid.loop.data import LoopData
from hmid.loop.design import Columns

_DRIFT_TIMES = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 1000.0)


class PressureLag(Candidate):
    name: ClassVar[str] = "pressure_lag"
    title: ClassVar[str] = "pressure measured late"
    physics: ClassVar[str] = (
        "the pressure that acts leads the measured one by a delay d (sensor tubing, filtering, "
        "sensor far from the muscle): the model is given P(t + d) instead of P(t)"
    )
    hyper: ClassVar[tuple[str, str]] = ("d", "s")
    grid: ClassVar[tuple[float, ...]] = tuple(np.round(np.arange(0.0, 0.1001, 0.0025), 4))
    tail_s: ClassVar[float] = 0.1
    edges_identified: ClassVar[tuple[bool, bool]] = (False, False)

    def transform(self, data: LoopData, value):
        if not value:
            return data
        t, P, shifted = data["t"], data["P"], np.empty(len(data))
        for rows in data.segments():
            # past the segment end the lead is unknown; those rows are never fitted (tail_s)
            shifted[rows] = np.interp(t[rows] + value, t[rows], P[rows])
        return data.with_columns(P=shifted)


def _drift(data: LoopData, tau: float) -> np.ndarray:
    """1 - exp(-t/T), scaled to 1 at the longest segment's last time: its coefficient is the
    change over that span whatever T, so a long T is a straight-line drift, not a huge number."""
    t = data["t"]
    return np.expm1(-t / tau) / np.expm1(-t.max() / tau)


class StiffnessDrift(Candidate):
    name: ClassVar[str] = "stiffness_drift"
    title: ClassVar[str] = "stiffness drift"
    physics: ClassVar[str] = (
        "the elastic force changes slowly over a test, (1 - f g(t)) x elastic force with "
        "g = (1 - exp(-t/T)) scaled to 1 at the end of the longest log: the latex warms up or "
        "its network relaxes (f > 0: softening by the fraction f over the test)"
    )
    hyper: ClassVar[tuple[str, str]] = ("T", "s")
    grid: ClassVar[tuple[float, ...]] = _DRIFT_TIMES

    def columns(self, data, value, elastic):
        return Columns.of(len(data), f=(_drift(data, value) * elastic, "1"))


class ForceZeroDrift(Candidate):
    name: ClassVar[str] = "force_zero_drift"
    title: ClassVar[str] = "force sensor zero drift"
    physics: ClassVar[str] = (
        "the force channel's zero moves slowly over a test (temperature, creep of the strain "
        "gauge): F_read = F + D g(t), g as for stiffness drift, D the drift over the test"
    )
    hyper: ClassVar[tuple[str, str]] = ("T", "s")
    grid: ClassVar[tuple[float, ...]] = _DRIFT_TIMES

    def columns(self, data, value, elastic):
        return Columns.of(len(data), D=(_drift(data, value), "N"))
