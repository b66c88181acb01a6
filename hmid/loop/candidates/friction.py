"""Friction beyond the model's: a law (a Coulomb level, viscous, Stribeck) times a modulation (by
the direction of motion, by a channel, in time). Each refits the Coulomb level too (``dFc``): a
Coulomb fit to free-fall tests absorbs part of any other law, so its level is then biased; where
the model fits a Coulomb level of its own, ``dFc`` takes its place (the candidate refines it).

The plain level change (:func:`level`) is not a candidate: the loop refits it in its base, since
it is the first thing any other friction law changes (viscous friction in the free falls raises
their Coulomb level) and would otherwise win as the cheapest explanation of every one of them.

Not offered: a direction-dependent Coulomb *level*: on sliding rows it is a constant offset plus
a symmetric level, so it is not identifiable against the model's free offset.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import ClassVar

import numpy as np

from hmid.balance import Column, Signals, raw
from hmid.loop.candidates._base import Candidate, Setting, hyper, stack
from hmid.loop.candidates.drift import DRIFT_TIMES, drift

_LAWS = {
    "coulomb": ("a Coulomb level", "h", "friction of constant level against the motion"),
    "viscous": ("viscous friction", "b", "friction growing linearly with speed (a lubricated "
                "guide, fluid drag, or damping in the actuator: the balance cannot tell)"),
    "stribeck": ("Stribeck friction", "delta", "extra friction at low speed that fades as a "
                 "lubricant film builds up, delta exp(-(v/v_s)²): breakaway, stick-slip"),
}  # fmt: skip
STRIBECK_GRID = tuple(np.geomspace(0.001, 0.05, 18))


class Friction(Candidate):
    """``law`` times ``modulation``: None, "direction", a channel's name, or "t"."""

    kind: ClassVar[str] = "friction"
    friction: ClassVar[bool] = True

    def __init__(self, setting: Setting, law: str, modulation: str | None = None) -> None:
        super().__init__(setting)
        self.law, self.modulation = law, modulation
        what, self.parameter, physics = _LAWS[law]
        p = self.parameter
        self.name = law if modulation is None else f"{law}.{modulation}"
        channel = () if modulation in (None, "direction", "t") else (modulation,)
        self.requires = ("v", *channel)
        # a Coulomb level's change is a correction of the model's level: either sign
        self.positive = () if law == "coulomb" else (p,)
        if modulation is None:
            self.title, self.physics = what, physics
            if law == "coulomb":
                self.title = "a Coulomb level other than the model's"
                self.physics = (f"{physics}, at a level other than the model's (the free-fall "
                                f"tests', or none): the change dFc")  # fmt: skip
        elif modulation == "direction":
            self.title = f"direction-dependent {what}"
            self.physics = f"{physics}, with its own coefficient for each direction of motion"
            self.positive = (f"{p}_pos", f"{p}_neg")
        elif modulation == "t":
            self.title = f"{what} drifting in time"
            self.physics = (f"{physics}; the coefficient changes over the test by {p}_t g(t), "
                            f"g = 1 - exp(-t/T) scaled to 1 at the end")  # fmt: skip
        else:
            self.title = f"{what} changing with {modulation}"
            self.physics = (f"{physics}; its coefficient changes with {modulation}: "
                            f"{p} + {p}_{modulation} {modulation}")  # fmt: skip

    @classmethod
    def variants(cls, setting: Setting) -> Iterator[Friction]:
        if setting.friction_sign is None or setting.position is None:
            return
        channels = (setting.position, *setting.inputs)
        for law, modulations in (
            ("coulomb", (*channels, "t")),
            ("viscous", (None, "direction", *channels, "t")),
            ("stribeck", (None, "direction")),
        ):
            for modulation in modulations:
                yield cls(setting, law, modulation)

    @property
    def hyper(self):
        if self.law == "stribeck":
            return hyper("v_s", "m/s", STRIBECK_GRID, (False, False))
        if self.modulation == "t":
            return hyper("T", "s", DRIFT_TIMES)
        return None

    def _law(self, signals: Signals, value, name: str, factor, powers=None) -> Column:
        """The law times ``factor`` = (raw, smoothed) multiplier, as the smoothed force holds it:
        a law linear in v multiplies the smoothed velocity (smoothing it again would smooth it
        twice); a law nonlinear in v is evaluated on the velocity estimate, then smoothed."""
        raw_factor, smooth_factor = factor
        v = signals[raw("v")]
        if self.law == "viscous":
            values = signals["v"] * smooth_factor
            return self.column(signals, name, values, {"v": 1} | (powers or {}))
        law = np.sign(v)
        if self.law == "stribeck":
            law = law * np.exp(-((v / value) ** 2))
        return self.column(signals, name, signals.smooth(law * raw_factor), powers)

    def columns(self, signals, value):
        p, columns = self.parameter, []
        if self.modulation == "direction":
            v = signals[raw("v")]
            for side, moving in (("pos", v > 0), ("neg", v < 0)):
                mask = moving.astype(float)
                columns.append(self._law(signals, value, f"{p}_{side}", (mask, mask)))
        else:
            if self.law != "coulomb":
                columns.append(self._law(signals, value, p, (1.0, 1.0)))
            if self.modulation == "t":
                g = drift(signals, value)
                columns.append(self._law(signals, value, f"{p}_t", (g, g)))
            elif self.modulation is not None:
                c = self.modulation
                factor = (signals[raw(c)], signals[c])
                columns.append(self._law(signals, value, f"{p}_{c}", factor, {c: 1}))
        return stack(signals, *columns, self.coulomb_level(signals))

    def signs_hold(self, upper):
        if self.modulation == "direction":
            # the asymmetry is what the direction adds; the coefficients' common part trades off
            # against the model's own velocity-like terms (a viscoelastic arm), so only the
            # larger one must be friction against the motion
            return max(upper.values(), default=1.0) > 0
        return super().signs_hold(upper)

    @property
    def follows(self) -> str:
        if self.modulation == "direction":
            return "the direction of motion"
        return self.modulation or "speed"

    def special_case_of(self, other):
        if not isinstance(other, Friction) or other.name == self.name:
            return False
        return self.modulation is None and self.law == other.law  # a law is in its modulations


def level(setting: Setting) -> Friction | None:
    """The Coulomb level's change, refitted in the loop's base (None: the rig declares no
    friction sign, or has no position to move)."""
    if setting.friction_sign is None or setting.position is None:
        return None
    return Friction(setting, "coulomb")
