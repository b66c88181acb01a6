"""Friction beyond the model's: a law (a Coulomb level, viscous, Stribeck) times a modulation (by
the direction of motion, by a channel, in time). Each refits the Coulomb level too (``dFc``): a
Coulomb fit to free-fall tests absorbs part of any other law, so its level is then biased; where
the model fits a Coulomb level of its own, ``dFc`` takes its place (the candidate refines it).

The plain level change (:func:`level`) is not a candidate: the loop refits it in its base, since
it is the first thing any other friction law changes (viscous friction in the free falls raises
their Coulomb level) and would otherwise win as the cheapest explanation of every one of them.

Not offered: a direction-dependent Coulomb *level*: on sliding rows it is a constant offset plus
a symmetric level, so it is not identifiable against the model's free offset.

Friction is offered on every rig with a position. Where the rig declares none (no Coulomb term,
no ``friction_sign``), its sign is that of a force against the motion in the declared balance (a
damper's, else the inertia's: :func:`~hmid.loop.candidates._base.against_motion`), the plain
Coulomb level is a candidate ("Coulomb friction"), and its level, like every law's coefficient,
must be against the motion: every direction's coefficient too (a negative Stribeck excess on one
side is no friction).
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
        # a Coulomb level's change is a correction of the model's level: either sign; where
        # the rig declares no friction, the level is all the friction there is: against the
        # motion
        self.positive = () if law == "coulomb" else (p,)
        if not setting.declared and law == "coulomb":
            self.positive += ("dFc",)
        if modulation is None:
            self.title, self.physics = what, physics
            if law == "coulomb" and not setting.declared:
                self.title = "Coulomb friction"
                self.physics = (f"{physics}, which the rig does not declare: its level dFc, "
                                "against the motion")  # fmt: skip
            elif law == "coulomb":
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
        # the plain level is refitted in the base where the rig declares friction
        level = () if setting.declared else (None,)
        for law, modulations in (
            ("coulomb", (*level, *channels, "t")),
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
        # a law refits the declared Coulomb level beside it; where none is declared, the level
        # is a candidate of its own (with a damper declared, viscous + a level would be it)
        if self.setting.declared or self.law == "coulomb":
            columns.append(self.coulomb_level(signals))
        return stack(signals, *columns)

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
    friction, or has no position to move: a Coulomb level is then a candidate of its own)."""
    if setting.friction_sign is None or setting.position is None or not setting.declared:
        return None
    return Friction(setting, "coulomb")
