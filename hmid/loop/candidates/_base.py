"""Candidate effects: physics a fitted model may lack, each a :class:`Term`.

A candidate adds columns to the model's balance (or transforms a channel every term reads, as a
lagging sensor does) and names its parameters with units; its signs are fixed by the rig's
declared conventions, never by a refitted coefficient. Friction candidates enter the explained
quantity with the rig's friction sign (+1: friction adds to it, as for a motor that overcomes
it; -1: it subtracts, as for a load cell behind the friction), so each friction coefficient is
positive when it opposes the motion.

The library is *generated* from building blocks for each rig (:func:`library`): friction laws
(a Coulomb level, viscous, Stribeck) times modulations (by direction, by any channel, in time),
timing on any channel (a delay, a first-order lag), elastic changes and sensor drift. A new kind
is one module here: subclass :class:`Candidate`, set ``kind`` and implement
:meth:`Candidate.variants` (the instances it offers a rig) and :meth:`~Candidate.columns`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hmid.balance import Column, Columns, Hyper, RigSection, Signals, Term, raw
from hmid.balance.rig import DERIVED
from hmid.balance.terms import unit_of
from hmid.errors import ConfigError

CANDIDATES: dict[str, type[Candidate]] = {}
#: Channels a rig derives (never a modulation or a timing channel of their own).


@dataclass(frozen=True)
class Setting:
    """What a candidate needs to know of the rig: the friction sign and the channels."""

    friction_sign: int | None
    position: str | None
    channels: tuple[str, ...]
    dt: float | None = None  # the logs' sample period, once they are read (timing grids)
    # the rig declares its friction (a Coulomb term or friction_sign); where it does not, the
    # sign is that of a force against the motion in its balance, and friction is a hypothesis
    # (a Coulomb level is a candidate of its own, not refitted in the base)
    declared: bool = True
    # where the declared Coulomb level is taken as known: whence ("the free-fall estimate", "its
    # declared value"); the loop's refit of it is then a test of that hypothesis
    known_level: str | None = None
    known_se: float = 0.0  # its standard error (the free-fall estimate's; 0 for a value)
    fitted_level: str | None = None  # the declared Coulomb term's name where it is fitted

    @classmethod
    def of(cls, rig: RigSection) -> Setting:
        sign = rig.resolved_friction_sign
        if sign is not None:
            known, fitted = _levels(rig)
            return cls(sign, rig.position, rig.model_channels, known_level=known,
                       fitted_level=fitted)  # fmt: skip
        return cls(against_motion(rig), rig.position, rig.model_channels, declared=False)

    @property
    def inputs(self) -> tuple[str, ...]:
        """Logged channels other than the position (a pressure, a valve command)."""
        return tuple(c for c in self.channels if c not in DERIVED and c != self.position)


def _levels(rig: RigSection) -> tuple[str | None, str | None]:
    """Whence the declared Coulomb level is known, or the name of the one that is fitted."""
    from hmid.balance.kinds import CoulombTerm, SmoothCoulombTerm

    for term in rig.balance:
        if isinstance(term, CoulombTerm | SmoothCoulombTerm):
            if not term.known:
                return None, term.name
            return ("the free-fall estimate" if term.value is None else "its declared value"), None
    return None, None


def against_motion(rig: RigSection) -> int | None:
    """The sign with which a force against the motion enters the rig's explained quantity, from
    its declared balance: a damper (a term in v whose coefficient physics makes positive), else
    the inertia (a positive term in a: a force that drives a mass overcomes its friction as it
    does its inertia, u = m a + f). None if the balance has neither."""
    from hmid.balance.kinds import ChannelTerm

    for channel in ("v", "a"):
        for term in rig.balance:
            if isinstance(term, ChannelTerm) and term.channel == channel and term.positive:
                return term.sign
    return None


class Candidate(Term):
    """Base class; concrete kinds register by ``kind`` and offer :meth:`variants`."""

    kind: ClassVar[str] = ""
    friction: ClassVar[bool] = False  # its parameters are friction coefficients
    elastic: ClassVar[bool] = False  # it reads the fitted model's elastic force
    refines: ClassVar[bool] = True  # model columns its own span are replaced (see Term)

    name: str
    title: str
    physics: str
    requires: tuple[str, ...] = ()  # channels it reads
    positive: tuple[str, ...] = ()  # parameters that physics makes positive

    def __init__(self, setting: Setting) -> None:
        self.setting = setting

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.kind:
            CANDIDATES[cls.kind] = cls

    @classmethod
    def variants(cls, setting: Setting) -> Iterator[Candidate]:
        """The instances this kind offers a rig with ``setting`` (none it cannot show)."""
        yield from ()

    @property
    def reads(self):
        return self.requires

    @property
    def follows(self) -> str:
        """What the effect's size follows (a channel, "t", "speed"): what a test must vary,
        with the rest held, to show it."""
        return self.requires[0] if self.requires else "t"

    def signs_hold(self, upper: dict[str, float]) -> bool:
        """Whether fitted intervals (their ``upper`` bounds, by positive parameter present in
        the fit) are consistent with the physical signs. Monotone: what holds for some bounds
        holds for larger ones (the screen asks it of the estimates first)."""
        return all(u > 0 for u in upper.values())

    def special_case_of(self, other: Candidate) -> bool:
        """Whether ``other`` contains this effect (viscous in direction-dependent viscous): then
        the two are one explanation, refined, not rival ones."""
        return False

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"

    def __eq__(self, other: object) -> bool:  # equal candidates share cached columns
        return type(self) is type(other) and (self.name, self.setting) == (
            other.name,
            other.setting,
        )

    def __hash__(self) -> int:
        return hash((type(self), self.name, self.setting))

    # -- helpers for subclasses ---------------------------------------------------------------
    @property
    def sign(self) -> int:
        sign = self.setting.friction_sign if self.friction else 1
        if sign is None:  # friction candidates are offered only where the sign is known
            raise ValueError(f"candidate {self.name!r} needs the rig's friction sign")
        return sign

    def column(self, signals: Signals, name: str, values, powers=None, unit=None) -> Column:
        """A column ``name`` with the candidate's sign, unit from ``powers`` of channels."""
        unit = unit or unit_of(signals, powers or {})
        return Column(name, self.sign * np.asarray(values, dtype=float), unit,
                      name in self.positive, self.reads)  # fmt: skip

    def coulomb_level(self, signals: Signals) -> Column:
        """The Coulomb level refitted alongside: a free-fall Coulomb fit absorbs part of any
        other friction law (a viscous one, say), so its level is biased when that law is real."""
        return self.column(signals, "dFc", direction(signals))


def direction(signals: Signals) -> np.ndarray:
    """sign(v) of the velocity estimate, through the smoother (as the force containing it);
    computed once per signals (every friction candidate refits the Coulomb level with it)."""
    return signals.derived(("direction",), lambda: signals.smooth(np.sign(signals[raw("v")])))


def stack(signals: Signals, *columns: Column) -> Columns:
    return Columns.stack(len(signals), list(columns))


def hyper(name: str, unit: str, grid, edges=(True, True), log=True) -> Hyper:
    return Hyper(name, unit, tuple(float(g) for g in grid), edges, log)


def library(setting: Setting) -> dict[str, Candidate]:
    """Every candidate the rig can show, by name, in registry order."""
    out: dict[str, Candidate] = {}
    for cls in CANDIDATES.values():
        for candidate in cls.variants(setting):
            out[candidate.name] = candidate
    return out


def make_candidates(names, setting: Setting) -> tuple[Candidate, ...]:
    available = library(setting)
    unknown = [n for n in names if n not in available]
    if unknown:
        raise ConfigError(
            f"loop.candidates: {unknown} are not effects this rig can show; it offers "
            f"{sorted(available)}"
        )
    return tuple(available[n] for n in names)
