"""Candidate effects: physics a fitted model may lack, each a small :class:`Term` subclass.

A candidate adds columns to the model's balance (or transforms a channel every term reads, as a
lagging sensor does) and names its parameters with units; its signs are fixed by the rig's
declared conventions, never by a refitted coefficient. Friction candidates enter the explained
quantity with the rig's friction sign (+1: friction adds to it, as for a motor that overcomes
it; -1: it subtracts, as for a load cell behind the friction), so each fitted friction parameter
is positive when it opposes the motion.

A new candidate is one module (or class) here: subclass :class:`Candidate`, set ``name``
(registry key), ``title``, ``physics`` and ``requires`` (the channels it reads), and implement
:meth:`columns` (and :attr:`hyper` for one profiled parameter).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from hmid.balance import Column, Columns, Hyper, RigSection, Signals, Term, raw
from hmid.balance.terms import unit_of
from hmid.errors import ConfigError

CANDIDATES: dict[str, type[Candidate]] = {}


@dataclass(frozen=True)
class Setting:
    """What a candidate needs to know of the rig: the friction sign and the channels."""

    friction_sign: int | None
    position: str | None
    channels: tuple[str, ...]

    @classmethod
    def of(cls, rig: RigSection) -> Setting:
        return cls(rig.resolved_friction_sign, rig.position, rig.model_channels)


class Candidate(Term):
    """Base class; subclasses register by ``name``."""

    name: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()  # channels it reads
    friction: ClassVar[bool] = False  # its parameters are friction coefficients
    elastic: ClassVar[bool] = False  # it scales the fitted model's elastic force
    positive: ClassVar[tuple[str, ...]] = ()  # parameters that physics makes positive

    def __init__(self, setting: Setting) -> None:
        self.setting = setting

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.name:
            CANDIDATES[cls.name] = cls

    @classmethod
    def missing(cls, setting: Setting) -> str | None:
        """Why the candidate does not apply to a rig (None if it does)."""
        absent = [c for c in cls.requires if c not in setting.channels]
        if absent:
            return f"reads {absent}, which the rig does not give"
        if cls.friction and setting.friction_sign is None:
            return "needs the rig's friction sign (a Coulomb term, or rig.friction_sign)"
        return None

    @property
    def reads(self):
        return self.requires

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def __eq__(self, other: object) -> bool:  # equal candidates share cached columns
        return type(self) is type(other) and self.setting == other.setting

    def __hash__(self) -> int:
        return hash((type(self), self.setting))

    # -- helpers for subclasses ---------------------------------------------------------------
    @property
    def sign(self) -> int:
        return self.setting.friction_sign if self.friction else 1

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
    """sign(v) of the velocity estimate, through the smoother (as the force containing it)."""
    return signals.smooth(np.sign(signals[raw("v")]))


def stack(signals: Signals, *columns: Column) -> Columns:
    return Columns.stack(len(signals), list(columns))


def make_candidates(names, setting: Setting) -> tuple[Candidate, ...]:
    unknown = [n for n in names if n not in CANDIDATES]
    if unknown:
        raise ConfigError(
            f"loop.candidates: unknown effect(s) {unknown}; known: {sorted(CANDIDATES)}"
        )
    return tuple(CANDIDATES[n](setting) for n in names)


def hyper(name: str, unit: str, grid, edges=(True, True), log=True) -> Hyper:
    return Hyper(name, unit, tuple(grid), edges, log)
