"""Friction laws beyond Coulomb. Each refits the Coulomb level too (``dFc``): when the true law is
not Coulomb, a Coulomb fit to free-fall tests absorbs part of it, so the level is biased."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from hmid.loop.candidates._base import Candidate, direction
from hmid.loop.design import Columns


class ViscousFriction(Candidate):
    name: ClassVar[str] = "viscous"
    friction: ClassVar[bool] = True
    title: ClassVar[str] = "viscous friction"
    physics: ClassVar[str] = (
        "friction growing linearly with speed, b v (lubricated guide, fluid drag, or damping "
        "in the muscle itself: the force balance cannot tell them apart)"
    )

    positive: ClassVar[tuple[str, ...]] = ("b",)

    def columns(self, data, value, elastic):
        n, s = len(data), direction(data)
        return Columns.of(n, b=(-data["v"], "N·s/m"), dFc=(-s, "N"))


class StribeckFriction(Candidate):
    name: ClassVar[str] = "stribeck"
    friction: ClassVar[bool] = True
    title: ClassVar[str] = "Stribeck friction"
    physics: ClassVar[str] = (
        "extra friction at low speed that fades as a lubricant film builds up, "
        "delta exp(-(v/v_s)²) sign(v): breakaway above sliding friction, stick-slip"
    )
    hyper: ClassVar[tuple[str, str]] = ("v_s", "m/s")
    grid: ClassVar[tuple[float, ...]] = tuple(np.geomspace(0.001, 0.05, 18))
    edges_identified: ClassVar[tuple[bool, bool]] = (False, False)
    positive: ClassVar[tuple[str, ...]] = ("delta",)

    def columns(self, data, value, elastic):
        n, s, v = len(data), direction(data), data["v"]
        return Columns.of(n, delta=(-s * np.exp(-((v / value) ** 2)), "N"), dFc=(-s, "N"))


class PressureFriction(Candidate):
    name: ClassVar[str] = "pressure_friction"
    friction: ClassVar[bool] = True
    title: ClassVar[str] = "pressure-dependent friction"
    physics: ClassVar[str] = (
        "friction proportional to pressure, mu P sign(v): a pressurised seal or sheath pressed "
        "harder on its guide"
    )

    positive: ClassVar[tuple[str, ...]] = ("mu",)

    def columns(self, data, value, elastic):
        n, s = len(data), direction(data)
        return Columns.of(n, mu=(-s * data["P"], "N/Pa"), dFc=(-s, "N"))


class Hysteresis(Candidate):
    """Only the level: its shape would be collinear with pressure friction, since on a muscle
    rig elongation follows pressure (sign(v) x ~ sign(v) (a + b P))."""

    name: ClassVar[str] = "hysteresis"
    friction: ClassVar[bool] = True
    title: ClassVar[str] = "direction-dependent force (hysteresis band)"
    physics: ClassVar[str] = (
        "a force offset that changes sign with the direction of motion, -h sign(v): a "
        "rate-independent hysteresis band of the latex and sheath between loading and "
        "unloading, or friction above the free-fall estimate; h > 0 (a band dissipates: a "
        "level *below* the free-fall estimate points at friction that grows with speed, "
        "since free falls are fast)"
    )
    positive: ClassVar[tuple[str, ...]] = ("h",)

    def columns(self, data, value, elastic):
        return Columns.of(len(data), h=(-direction(data), "N"))
