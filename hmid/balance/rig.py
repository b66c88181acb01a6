"""The ``rig:`` section of an experiment: a rig's physics declared as a force balance.

::

    rig:
      name: linear-motor stage
      convention: x is the carriage position (positive away from the motor); u > 0 pushes +x
      channels: {x: {}, u: {}}        # log channels the model may read, with their sign
      position: x                     # v = dx/dt and a = d²x/dt² are derived from it
      explained: u                    # the measured quantity the balance explains
      balance:                        # explained = sum of terms (signs built in)
        - {kind: channel, name: M, channel: a, positive: true, unit: kg}
        - {kind: channel, name: Fv, channel: v, positive: true}
        - {kind: coulomb, name: Fc}
        - {kind: constant, name: offset}

``explained`` is a channel, or a sum of known terms (a rig without a force sensor explains its
inertial force: ``{name: ..., parts: [{channel: a, value: 0.75, unit: kg}, {value: 4.903,
unit: N}]}``). ``free_fall`` declares the free-fall friction tests (``mass`` dragged along the
rail by ``drive``), ``motion`` how the explained quantity follows from the acceleration
(``mass * a + offset``, for free-run simulations). A channel whose logged sign is the reverse
of the convention is declared ``{sign: -1}``. Term kinds: :mod:`hmid.balance.kinds`.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializeAsAny, field_validator, model_validator

from hmid.balance.kinds import (
    CoulombTerm,
    ModelSlot,
    Name,
    SmoothCoulombTerm,
    TermSpec,
    make_term,
)
from hmid.balance.monomial import Monomial
from hmid.config import Positive
from hmid.errors import ConfigError
from hmid.io.plausibility import MAX_ACCELERATION, MAX_SPEED, Limits

DERIVED = ("v", "a")


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class RigChannel(_Frozen):
    """A log channel the model may read. ``sign: -1`` when the logger counts it the other way
    than the rig's convention (the channel is negated on loading). What the rig can do, in SI
    units, for the plausibility checks (:mod:`hmid.io.plausibility`): ``range`` of the values,
    and for the position ``max_speed`` and ``max_acceleration`` (defaults 10 m/s, 1000 m/s²)."""

    sign: Literal[1, -1] = 1
    description: str = ""
    range: tuple[float, float] | None = None
    max_speed: Positive | None = None
    max_acceleration: Positive | None = None

    @field_validator("range")
    @classmethod
    def _ordered(cls, value):
        if value is not None and not value[0] < value[1]:
            raise ValueError("range must be [low, high] with low < high")
        return value


class KnownPart(_Frozen):
    """A known part of the explained quantity: ``value`` [``unit``] times ``channel`` (a channel,
    power or product; ``"1"`` for a constant)."""

    channel: str = "1"
    value: float = 1.0
    unit: str | None = None
    name: str = ""

    def powers(self) -> dict[str, int]:
        return dict(Monomial.parse(self.channel).powers)


class Explained(_Frozen):
    """The measured quantity the balance explains: the sum of ``parts``."""

    name: str
    parts: Annotated[tuple[KnownPart, ...], Field(min_length=1)]

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(c for p in self.parts for c in p.powers()))


class FreeFall(_Frozen):
    """Free-fall friction tests: with the actuator disconnected, ``drive`` [N] drags the moving
    ``mass`` [kg] and only friction opposes it: mass u'' = drive - friction."""

    mass: Positive
    drive: Positive


class Motion(_Frozen):
    """``explained = mass * a + offset``: how the explained quantity follows from the motion
    (the load cell of thesis eq. 4.2), so that a fitted force can be run free."""

    mass: Positive
    offset: float = 0.0


class RigSection(_Frozen):
    """A rig declared as a force balance; see the module docstring."""

    name: str = "rig"
    convention: str = ""
    channels: Annotated[dict[Name, RigChannel], Field(min_length=1)]
    position: str | None = None
    explained: Explained
    balance: Annotated[tuple[SerializeAsAny[TermSpec], ...], Field(min_length=1)]
    free_fall: FreeFall | None = None
    motion: Motion | None = None
    friction_sign: Literal[1, -1] | None = None

    @field_validator("explained", mode="before")
    @classmethod
    def _channel_shorthand(cls, value):
        if isinstance(value, str):
            return {"name": value, "parts": [{"channel": value}]}
        return value

    @field_validator("balance", mode="before")
    @classmethod
    def _terms(cls, specs):
        if not isinstance(specs, list | tuple):
            raise ValueError("must be a list of terms, each with a 'kind'")
        return tuple(make_term(spec, f"term {i}") for i, spec in enumerate(specs))

    @model_validator(mode="after")
    def _consistent(self) -> RigSection:
        channels = self.model_channels
        if self.position is not None and self.position not in self.channels:
            raise ValueError(
                f"position {self.position!r} is not among channels {list(self.channels)}"
            )
        for name, spec in self.channels.items():
            if name != self.position and (spec.max_speed or spec.max_acceleration):
                raise ValueError(
                    f"channels.{name}: max_speed and max_acceleration are the position's "
                    f"({self.position}); give them there"
                )
        taken = [c for c in DERIVED if c in self.channels and self.position is not None]
        if taken:
            raise ValueError(f"channel names {taken} are derived from the position; rename them")
        for i, part in enumerate(self.explained.parts):
            derived = [c for c in part.powers() if c in DERIVED and c not in channels]
            if derived:
                raise ValueError(f"explained part {i} reads {derived}: declare the position")
        names = [t.name for t in self.balance]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"balance terms share names {repeated}; give each its own name")
        if sum(isinstance(t, ModelSlot) for t in self.balance) > 1:
            raise ValueError("at most one {kind: model} slot: one actuator force per balance")
        # a logged channel of the explained quantity (a force sensor) is no regressor; a derived
        # one in a known part (the acceleration of a weighed mass) may be one as well
        explained = set(self.explained.channels) - set(DERIVED)
        for i, term in enumerate(self.balance):
            reads = set(term.reads)
            unknown = sorted(reads - set(channels))
            if unknown:
                raise ValueError(f"term {i} ({term.name}) reads {unknown}, not among {channels}")
            if reads & explained:
                raise ValueError(
                    f"term {i} ({term.name}) reads the explained quantity's channel "
                    f"{sorted(reads & explained)}: a model cannot use what it explains"
                )
            if term.known and term.hyper is not None:
                raise ValueError(
                    f"term {i} ({term.name}) has a known coefficient: fix its parameter too"
                )
            if isinstance(term, CoulombTerm) and term.source == "free_fall" and not self.free_fall:
                raise ValueError(
                    f"term {i} ({term.name}) is from: free_fall; add a free_fall section"
                )
        if not self.fitted and self.slot is None:
            raise ValueError("every term of the balance is known: there is nothing to identify")
        signs = {t.sign for t in self.balance if isinstance(t, CoulombTerm | SmoothCoulombTerm)}
        if len(signs) > 1:
            raise ValueError("the Coulomb terms enter with different signs; friction has one")
        if signs and self.friction_sign is not None and signs != {self.friction_sign}:
            raise ValueError(
                f"friction_sign {self.friction_sign} contradicts the Coulomb terms' sign "
                f"{signs.pop()}"
            )
        return self

    # -- what the rest of hmid reads ------------------------------------------------------------
    @property
    def model_channels(self) -> tuple[str, ...]:
        """Channels a model may read: the declared ones, then v and a from the position."""
        derived = DERIVED if self.position is not None else ()
        return (*self.channels, *derived)

    @property
    def log_channels(self) -> tuple[str, ...]:
        """Channels every dynamic log must have (the model's and the explained quantity's)."""
        derived = DERIVED if self.position is not None else ()
        names = dict.fromkeys((*self.channels, *self.explained.channels))
        return tuple(c for c in names if c not in derived)

    def limits(self):
        """What the rig can do (:class:`hmid.io.plausibility.Limits`), declared or default."""
        position = self.channels.get(self.position) if self.position else None
        return Limits(
            max_speed=(position.max_speed if position else None) or MAX_SPEED,
            max_acceleration=(position.max_acceleration if position else None) or MAX_ACCELERATION,
            ranges={c: s.range for c, s in self.channels.items() if s.range is not None},
        )

    @property
    def slot(self) -> ModelSlot | None:
        return next((t for t in self.balance if isinstance(t, ModelSlot)), None)

    @cached_property
    def fitted(self) -> tuple[TermSpec, ...]:
        """Terms whose coefficients are identified (not the slot, not known)."""
        return tuple(t for t in self.balance if not isinstance(t, ModelSlot) and not t.known)

    @property
    def known(self) -> tuple[TermSpec, ...]:
        """Terms with known coefficients (a value, or friction from the free-fall tests)."""
        return tuple(t for t in self.balance if not isinstance(t, ModelSlot) and t.known)

    @property
    def from_free_fall(self) -> tuple[CoulombTerm, ...]:
        return tuple(
            t for t in self.balance if isinstance(t, CoulombTerm) and t.source == "free_fall"
        )

    @property
    def declares_friction(self) -> bool:
        """Whether a term models friction (a Coulomb law, smooth or from the free falls): what
        the low-speed rule of ``fit.exclude_stuck`` is meant for."""
        return any(isinstance(t, CoulombTerm | SmoothCoulombTerm) for t in self.balance)

    @property
    def resolved_friction_sign(self) -> int | None:
        """+1 if friction enters the explained quantity as +f (a motor force balancing it), -1 as
        -f (a load cell behind the friction): declared by the Coulomb terms or ``friction_sign``."""
        for term in self.balance:
            if isinstance(term, CoulombTerm | SmoothCoulombTerm):
                return term.sign
        return self.friction_sign

    def units(self, log_units: Mapping[str, str]) -> dict[str, str]:
        """SI units of every model channel and of ``target`` (the explained quantity), from the
        units of the logged channels; ConfigErrors name the term whose declared unit is wrong."""
        from hmid.io.units import si_unit

        units = {c: log_units[c] for c in self.log_channels}
        if self.position is not None:
            position = units[self.position]
            units["v"] = si_unit(f"({position})/s", "derived")
            units["a"] = si_unit(f"({position})/s^2", "derived")
        units["target"] = self._explained_unit(units)
        return units

    def _explained_unit(self, units: Mapping[str, str]) -> str:
        from hmid.io.units import format_unit, unit_registry

        ureg = unit_registry()
        found = []
        for i, part in enumerate(self.explained.parts):
            unit = ureg.parse_units(part.unit) if part.unit else ureg.dimensionless
            for channel, power in part.powers().items():
                unit = unit * ureg.parse_units(units[channel]) ** power
            found.append((i, unit))
        reference = found[0][1]
        for i, unit in found[1:]:
            if unit.dimensionality != reference.dimensionality:
                raise ConfigError(
                    f"rig.explained.parts.{i}: its unit {format_unit(unit)} is not that of part 0 "
                    f"({format_unit(reference)}): the parts of a sum must be the same quantity"
                )
        from hmid.io.units import si_unit

        return si_unit(str(reference), "explained")

    def part_values(self, units: Mapping[str, str]) -> list[float]:
        """Each explained part's ``value`` in SI (its unit converted)."""
        return [
            _to_si(part.value, part.unit, _part_unit(part, units), units["target"], f"parts.{i}")
            for i, part in enumerate(self.explained.parts)
        ]

    def term_value(self, term: TermSpec, units: Mapping[str, str]) -> float:
        """A known term's coefficient in SI (its declared unit converted)."""
        from hmid.balance.terms import implied_unit

        parts = tuple((units[c], float(p)) for c, p in sorted(term.powers().items()))
        si = implied_unit(units["target"], parts)
        if term.value is None:
            raise ConfigError(f"rig.balance: term {term.name!r} has no known value")
        return _to_si(float(term.value), term.unit or si, si, None, term.name)

    def check_units(self, units: Mapping[str, str], source: str) -> None:
        """Every declared ``unit`` has the dimension the balance implies (one-line errors)."""
        from hmid.balance.terms import implied_unit
        from hmid.io.units import unit_registry

        ureg = unit_registry()
        for i, term in enumerate(self.balance):
            if term.unit is None or isinstance(term, ModelSlot):
                continue
            parts = tuple((units[c], float(p)) for c, p in sorted(term.powers().items()))
            implied = implied_unit(units["target"], parts)
            try:
                declared = ureg.parse_units(term.unit)
            except Exception:
                raise ConfigError(
                    f"{source}: key 'rig.balance.{i}.unit': unknown unit {term.unit!r}"
                ) from None
            if declared.dimensionality != ureg.parse_units(implied).dimensionality:
                raise ConfigError(
                    f"{source}: key 'rig.balance.{i}.unit': {term.unit!r} is not a unit of "
                    f"{term.name}, which the balance makes {implied} (explained quantity in "
                    f"{units['target']}); check the term's channel, its unit, or the explained "
                    "quantity"
                )


def _part_unit(part: KnownPart, units: Mapping[str, str]) -> str:
    from hmid.balance.terms import implied_unit

    parts = tuple((units[c], float(p)) for c, p in sorted(part.powers().items()))
    return implied_unit(units["target"], parts)


def _to_si(value: float, unit: str | None, si: str, target: str | None, where: str) -> float:
    if unit is None:
        return float(value)
    from hmid.io.units import unit_registry

    ureg = unit_registry()
    try:
        return float(
            ureg.Quantity(value, ureg.parse_units(unit)).to(ureg.parse_units(si)).magnitude
        )
    except Exception:
        raise ConfigError(
            f"rig {where}: a value in {unit!r} cannot be a coefficient in {si}; check its unit"
        ) from None
