"""The term kinds a rig config declares (``rig.balance``): typed configs that are :class:`Term` s.

Every kind has ``name`` (its parameter), ``sign`` (+1 or -1: how the term enters
``explained = sum of terms``), ``positive`` (physics makes the parameter positive: a mass, a
stiffness, a friction level; a fit with the whole interval below zero is flagged), an optional
``unit`` (checked against the unit the balance implies) and an optional ``value`` (a known
coefficient, e.g. a weighed mass, in ``unit`` or SI). Kinds:

=================  =========================================================================
``constant``       an offset
``channel``        a channel, a power or a product of channels: ``a``, ``x^3``, ``x*P``
``coulomb``        sign of the velocity (Coulomb friction); ``from: free_fall`` takes its law
                   from the free-fall tests
``smooth_coulomb`` tanh(v / ``scale``), a smooth sign
``memory``         a viscoelastic (Maxwell) arm g_tau(channel), dg/dt = -g/tau + d(channel)/dt,
                   tau fixed or profiled on a grid
``lag``            a channel seen through a pure ``delay`` or a ``first_order`` lag, its time
                   fixed or profiled
``model``          the slot a model family (polynomial, SINDy, SLS) fills with its force
=================  =========================================================================

A new kind is one subclass here (it registers itself by its ``kind``).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from hmid._registry import from_registry
from hmid.balance.columns import Column, Columns
from hmid.balance.monomial import Monomial
from hmid.balance.operations import lagged, memory_response
from hmid.balance.signals import Signals, raw
from hmid.balance.terms import Hyper, Term, unit_of

TERM_KINDS: dict[str, type[TermSpec]] = {}
Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=40)]


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Grid(_Frozen):
    """A profiled parameter's search grid: ``points`` values from ``min`` to ``max``."""

    min: Annotated[float, Field(ge=0)]
    max: Annotated[float, Field(gt=0)]
    points: Annotated[int, Field(ge=2, le=400)] = 40
    scale: Literal["log", "linear"] = "log"

    @model_validator(mode="after")
    def _ordered(self) -> Grid:
        if self.max <= self.min:
            raise ValueError(f"max={self.max} must exceed min={self.min}")
        if self.scale == "log" and self.min <= 0:
            raise ValueError("a log-scaled grid needs min > 0 (use scale: linear to include 0)")
        return self

    def values(self) -> tuple[float, ...]:
        space = np.geomspace if self.scale == "log" else np.linspace
        return tuple(float(v) for v in space(self.min, self.max, self.points))


class TermSpec(_Frozen, Term):
    """Fields every declared term has; see the module docstring."""

    kind: str
    name: Name
    sign: Literal[1, -1] = 1
    positive: bool = False
    unit: str | None = None
    value: float | None = None
    description: str = ""
    known_from: ClassVar[str | None] = None  # where a known coefficient comes from, if not value

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs):
        super().__pydantic_init_subclass__(**kwargs)
        default = cls.model_fields["kind"].default
        if isinstance(default, str) and default:
            TERM_KINDS[default] = cls

    @property
    def known(self) -> bool:
        """The coefficient is known (a value, or the free-fall friction): not fitted."""
        return self.value is not None

    def powers(self) -> dict[str, int]:
        """Channels (and powers) of the regressor, for its unit."""
        return {}

    def _column(self, signals: Signals, values: np.ndarray) -> Columns:
        column = Column(
            self.name,
            self.sign * np.asarray(values, dtype=float),
            unit_of(signals, self.powers(), self.unit),
            self.positive,
            self.reads,
        )
        return Columns.stack(len(signals), [column])

    @classmethod
    def example(cls) -> TermSpec:
        """A valid instance on channels x and P (for contract tests and documentation)."""
        return cls.model_validate({"name": "c"})  # a subclass: its kind has a default

    def label(self) -> str:
        return self.description or self.name

    def regressor(self) -> str:
        """The regressor as text, for equations ("a", "x³", "sign(v)"; "1" for a constant)."""
        return "1"


class ConstantTerm(TermSpec):
    kind: Literal["constant"] = "constant"

    def columns(self, signals, value):
        return self._column(signals, np.ones(len(signals)))


class ChannelTerm(TermSpec):
    """A channel, a power or a product of channels (``x``, ``x^3``, ``x*P``), as smoothed.

    A single channel is the smoothed channel. A power or product of logged channels is
    evaluated on the raw signals and smoothed after, as the measured force that contains it was:
    the product of smoothed signals differs from the smoothed product by the signals' variation
    within the kernel (for x³ by ≈ 3x·var(x): it grows as v² and is the same in both directions,
    so a loop would read it as friction). Products with v or a, derivatives of the smoothed
    position, stay products of smoothed signals.
    """

    kind: Literal["channel"] = "channel"
    channel: str

    @classmethod
    def example(cls):
        return cls(name="k", channel="x^3", sign=-1, positive=True)

    @model_validator(mode="after")
    def _parse(self) -> ChannelTerm:
        self.powers()  # a ConfigError names the bad text
        return self

    def powers(self) -> dict[str, int]:
        return dict(Monomial.parse(self.channel).powers)

    @property
    def reads(self):
        return tuple(self.powers())

    def regressor(self):
        return Monomial.parse(self.channel).pretty

    def of_smoothed(self, signals) -> bool:
        """Whether the column is the product of smoothed channels (row by row), rather than
        a product of raw ones smoothed after (which needs whole segments)."""
        powers = self.powers()
        logged = all(signals.is_logged(channel) for channel in powers)
        return sum(powers.values()) == 1 or not logged

    def columns(self, signals, value):
        powers = self.powers()
        if self.of_smoothed(signals):
            # linear: smoothing commutes with it; v and a are derivatives of the smoothed
            # position, with no unsmoothed version to evaluate a product on
            smoothed = {c: signals[c] for c in powers}
            return self._column(signals, channel_product(smoothed, powers, slice(None)))
        unsmoothed = {c: signals[raw(c)] for c in powers}
        return self._column(
            signals, signals.smooth(channel_product(unsmoothed, powers, slice(None)))
        )


def channel_product(columns, powers, rows) -> np.ndarray:
    """The product of ``columns[c] ** powers[c]`` on ``rows`` (a slice or indices), multiplied in
    the order of ``powers``: what :class:`ChannelTerm` evaluates, on any rows alone."""
    values = np.ones(len(next(iter(columns.values()))[rows]))
    for channel, power in powers.items():
        values = values * columns[channel][rows] ** power
    return values


class CoulombTerm(TermSpec):
    """Friction of constant level opposing motion: sign(v), evaluated on the velocity estimate
    and then smoothed (as the measured force that contains it)."""

    kind: Literal["coulomb"] = "coulomb"
    positive: bool = True
    channel: str = "v"
    source: Literal["free_fall"] | None = Field(None, alias="from")

    model_config = ConfigDict(populate_by_name=True)

    @model_validator(mode="after")
    def _one_source(self) -> CoulombTerm:
        if self.source is not None and self.value is not None:
            raise ValueError("give either a value or from: free_fall, not both")
        return self

    @property
    def known(self) -> bool:
        return self.value is not None or self.source is not None

    @property
    def reads(self):
        return (self.channel,)

    def regressor(self):
        return f"sign({self.channel})"

    def columns(self, signals, value):
        return self._column(signals, signals.smooth(np.sign(signals[raw(self.channel)])))


class SmoothCoulombTerm(TermSpec):
    """tanh(v / scale): Coulomb friction with a smooth sign (``scale`` in the channel's unit)."""

    kind: Literal["smooth_coulomb"] = "smooth_coulomb"
    positive: bool = True
    channel: str = "v"
    scale: Annotated[float, Field(gt=0)]

    @classmethod
    def example(cls):
        return cls(name="Fs", scale=0.001, sign=-1)

    @property
    def reads(self):
        return (self.channel,)

    def regressor(self):
        return f"tanh({self.channel}/{self.scale:g})"

    def columns(self, signals, value):
        return self._column(
            signals, signals.smooth(np.tanh(signals[raw(self.channel)] / self.scale))
        )


@lru_cache(maxsize=256)  # a term's grid is asked for at every fit of a profile
def _hyper(setting: float | Grid, name: str, unit: str, edges=(True, True)) -> Hyper | None:
    if isinstance(setting, Grid):
        return Hyper(name, unit, setting.values(), edges, setting.scale == "log")
    return None


def _fixed(setting: float | Grid, value: float | None) -> float:
    if value is not None:
        return float(value)
    if isinstance(setting, Grid):
        raise ValueError("a profiled term needs a value of its parameter")
    return float(setting)


class MemoryTerm(TermSpec):
    """A Maxwell arm on ``channel``: dg/dt = -g/tau + d(channel)/dt from rest at each segment
    start; its coefficient is the arm's stiffness (k2 for elongation). ``tau`` fixed or a grid;
    ``warmup_s``: rows after each segment start left out while the unknown history decays."""

    kind: Literal["memory"] = "memory"
    channel: str
    tau: float | Grid = Grid(min=0.01, max=5.0, points=40)
    warmup_s: Annotated[float, Field(ge=0)] = 0.0

    @classmethod
    def example(cls):
        return cls(name="k2", channel="x", sign=-1, positive=True, tau=Grid(min=0.02, max=2.0))

    def powers(self):
        return {self.channel: 1}

    @property
    def reads(self):
        return (self.channel,)

    @property
    def hyper(self):
        return _hyper(self.tau, f"tau_{self.name}", "s")

    def regressor(self):
        return f"g_tau({self.channel})"

    @property
    def margins(self):
        return (self.warmup_s, 0.0)

    def columns(self, signals, value):
        tau = _fixed(self.tau, value)
        return self._column(signals, memory_response(signals, self.channel, tau, self.hyper))


class LagTerm(TermSpec):
    """``channel`` seen through a pure ``delay`` (value at t - d) or a ``first_order`` lag
    (time constant T, starting in steady state); ``time`` fixed or a grid (scale linear to
    include 0)."""

    kind: Literal["lag"] = "lag"
    channel: str
    filter: Literal["delay", "first_order"] = "delay"
    time: float | Grid = Grid(min=0.0, max=0.1, points=41, scale="linear")

    @classmethod
    def example(cls):
        return cls(name="A", channel="P", positive=True)

    def powers(self):
        return {self.channel: 1}

    @property
    def reads(self):
        return (self.channel,)

    def regressor(self):
        return f"{self.filter}({self.channel})"

    @property
    def hyper(self):
        name = "d" if self.filter == "delay" else "T"
        return _hyper(self.time, f"{name}_{self.name}", "s", (False, False))

    @property
    def margins(self):
        longest = self.time.max if isinstance(self.time, Grid) else float(self.time)
        return (longest if self.filter == "delay" else 0.0, 0.0)

    def columns(self, signals, value):
        time = _fixed(self.time, value)
        return self._column(signals, lagged(signals, signals[self.channel], time, self.filter))


class ModelSlot(TermSpec):
    """The slot a model family fills with the actuator's force (e.g. the muscle force F_m)."""

    kind: Literal["model"] = "model"
    name: Name = "F_m"

    @classmethod
    def example(cls):
        return cls()

    def columns(self, signals, value):
        raise TypeError(f"the model slot {self.name!r} has no columns: a model family fills it")


def make_term(spec: Mapping[str, Any] | TermSpec, source: str = "rig.balance") -> TermSpec:
    """A term from ``{"kind": ..., ...}``; unknown kinds or keys are one-line ConfigErrors."""
    return from_registry(spec, TermSpec, TERM_KINDS, tag="kind", what="term kind", source=source)
