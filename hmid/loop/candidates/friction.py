"""Friction laws beyond Coulomb. Each refits the Coulomb level too (``dFc``): when the true law is
not Coulomb, a Coulomb fit to free-fall tests absorbs part of it, so the level is biased."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from hmid.balance import raw
from hmid.loop.candidates._base import Candidate, direction, hyper, stack


class ViscousFriction(Candidate):
    name: ClassVar[str] = "viscous"
    friction: ClassVar[bool] = True
    requires: ClassVar[tuple[str, ...]] = ("v",)
    title: ClassVar[str] = "viscous friction"
    physics: ClassVar[str] = (
        "friction growing linearly with speed, b v (lubricated guide, fluid drag, or damping "
        "in the actuator itself: the force balance cannot tell them apart)"
    )
    positive: ClassVar[tuple[str, ...]] = ("b",)

    def columns(self, signals, value):
        return stack(
            signals,
            self.column(signals, "b", signals["v"], {"v": 1}),
            self.coulomb_level(signals),
        )


class StribeckFriction(Candidate):
    name: ClassVar[str] = "stribeck"
    friction: ClassVar[bool] = True
    requires: ClassVar[tuple[str, ...]] = ("v",)
    title: ClassVar[str] = "Stribeck friction"
    physics: ClassVar[str] = (
        "extra friction at low speed that fades as a lubricant film builds up, "
        "delta exp(-(v/v_s)²) sign(v): breakaway above sliding friction, stick-slip"
    )
    positive: ClassVar[tuple[str, ...]] = ("delta",)

    @property
    def hyper(self):
        return hyper("v_s", "m/s", np.geomspace(0.001, 0.05, 18), (False, False))

    def columns(self, signals, value):
        v = signals[raw("v")]
        bump = signals.smooth(np.sign(v) * np.exp(-((v / value) ** 2)))
        return stack(signals, self.column(signals, "delta", bump), self.coulomb_level(signals))


class PressureFriction(Candidate):
    name: ClassVar[str] = "pressure_friction"
    friction: ClassVar[bool] = True
    requires: ClassVar[tuple[str, ...]] = ("v", "P")
    title: ClassVar[str] = "pressure-dependent friction"
    physics: ClassVar[str] = (
        "friction proportional to pressure, mu P sign(v): a pressurised seal or sheath pressed "
        "harder on its guide"
    )
    positive: ClassVar[tuple[str, ...]] = ("mu",)

    def columns(self, signals, value):
        values = signals.smooth(np.sign(signals[raw("v")]) * signals[raw("P")])
        return stack(
            signals, self.column(signals, "mu", values, {"P": 1}), self.coulomb_level(signals)
        )


class Hysteresis(Candidate):
    """Only the level: its shape would be collinear with pressure friction, since on a muscle
    rig elongation follows pressure (sign(v) x ~ sign(v) (a + b P))."""

    name: ClassVar[str] = "hysteresis"
    friction: ClassVar[bool] = True
    requires: ClassVar[tuple[str, ...]] = ("v",)
    title: ClassVar[str] = "direction-dependent force (hysteresis band)"
    physics: ClassVar[str] = (
        "a force offset that changes sign with the direction of motion, h sign(v) against the "
        "motion: a rate-independent hysteresis band between loading and unloading, or friction "
        "above the free-fall estimate; h > 0 (a band dissipates: a level *below* the free-fall "
        "estimate points at friction that grows with speed, since free falls are fast)"
    )
    positive: ClassVar[tuple[str, ...]] = ("h",)

    def columns(self, signals, value):
        return stack(signals, self.column(signals, "h", direction(signals)))
