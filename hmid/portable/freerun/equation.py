"""The rig's balance, with a model's terms in it, read as an equation of motion.

The explained quantity (a force sensor read as ``motion``: mass a + offset; or known parts such
as m a + m g; or a measured input such as a drive force) equals the sum of the terms. Both sides
are affine in the acceleration a, which the integrator solves for; the state is x, v and one
internal state per memory arm (dq/dt = -q/tau + v) and per first-order lag. This module only
reads the model file's terms into that form (:class:`Equation`) and says, in one line, why a
balance is not an equation of motion (:class:`NotSimulable`); it imports no JAX, so that a rig
that imposes its position says so without loading the integrator.

**Stick-slip.** sign(v) is replaced by tanh(v / v0): a regularisation, not an event. Below v0
the block creeps where the rig would stick, at v0 atanh(u / Fc) under a force u < Fc: on a rig
with a spring the error this costs is bounded by the stick band (about 2 Fc / k in position),
but a stage without one drifts by the creep for as long as it stands. So the free run's v0 is
as small as the integrator affords (:func:`free_run_v0`): near v = 0 the friction acts as a
damping Fc / (M v0), and the band's fixed steps of one sample dt stay stable while
dt Fc / (M v0) <= 2 (explicit Runge-Kutta methods of order 4-5 are stable to about 3 on the
negative real axis). It is never above the fit's low-speed cut-off ``fit.v_deadband`` (the
Coulomb level was fitted on faster rows), which :func:`equation` keeps by default (a
controller's inverse model reads it there). On the shipped linear stage this took the free
run from 97.2 to 99.8 % fit (v0 2 mm/s -> 0.1 mm/s). An event-driven stick phase would need
the static friction level, which free falls do not measure.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hmid.balance.kinds import (
    ChannelTerm,
    ConstantTerm,
    CoulombTerm,
    Grid,
    LagTerm,
    MemoryTerm,
    SmoothCoulombTerm,
    TermSpec,
)


class NotSimulable(ValueError):
    """The model's balance is not an equation of motion this integrator runs (one line: why)."""


def _fixed(term: TermSpec, value: float | Grid) -> float:
    """A profiled parameter's value (the exported file holds it in place of the grid)."""
    if isinstance(value, Grid):
        raise NotSimulable(f"term {term.name}: a grid, not a value, for its profiled parameter")
    return float(value)


@dataclass(frozen=True)
class Equation:
    """The balance as an equation of motion: per term, how to evaluate it on the state.

    ``terms``: (kind, data, coefficient) with kind one of "const", "mono" (powers of x, v and
    inputs), "accel" (coefficient of a), "tanh" (tanh(v / scale)), "memory" (state index),
    "lag" (state index, input, T), "delay" (input, d), "friction" (free-fall law Fc + b |v|).
    ``inputs``: the channels read from the log. ``lhs``: the explained quantity the same way."""

    rhs: tuple
    lhs: tuple
    inputs: tuple[str, ...]
    n_memory: int
    lags: tuple[tuple[str, float], ...]
    v0: float


@dataclass
class _Reading:
    """What reading one model's terms collects, in order of appearance: the channels read from
    the log, the memory arms' relaxation times and the lags' (input, time constant)."""

    position: str
    v0: float
    inputs: list[str] = field(default_factory=list)
    memory: list[float] = field(default_factory=list)
    lags: list[tuple[str, float]] = field(default_factory=list)

    def channel(self, name: str) -> str:
        """``name``, noted as an input unless it is the state (x, v, a)."""
        if name in (self.position, "v", "a"):
            return name
        if name not in self.inputs:
            self.inputs.append(name)
        return name

    def monomial(self, powers: dict[str, int]) -> tuple[tuple[str, int], ...]:
        """A product of channels' powers, its inputs noted."""
        return tuple((self.channel(c), p) for c, p in powers.items())

    def parts(self, term, coef: float) -> list[tuple[str, Any, float]]:
        """``term`` times ``coef`` as the equation's parts (kind, data, coefficient)."""
        s = term.sign * coef
        if isinstance(term, ConstantTerm):
            return [("const", None, s)]
        if isinstance(term, ChannelTerm):
            powers = term.powers()
            if "a" in powers:
                if powers != {"a": 1}:
                    raise NotSimulable(f"term {term.name} ({term.channel}) is not linear in a")
                return [("accel", None, s)]
            return [("mono", self.monomial(powers), s)]
        if isinstance(term, CoulombTerm):
            if term.channel != "v":
                raise NotSimulable(f"term {term.name}: sign of {term.channel}")
            return [("tanh", self.v0, s)]
        if isinstance(term, SmoothCoulombTerm):
            return [("tanh", float(term.scale), s)]
        if isinstance(term, MemoryTerm):
            if term.channel != self.position:
                raise NotSimulable(f"term {term.name}: a memory arm of {term.channel}")
            self.memory.append(_fixed(term, term.tau))
            return [("memory", (len(self.memory) - 1, _fixed(term, term.tau)), s)]
        if isinstance(term, LagTerm):
            if term.channel in (self.position, "v", "a"):
                raise NotSimulable(f"term {term.name}: a lag of the state {term.channel}")
            name = self.channel(term.channel)
            if term.filter == "delay":
                return [("delay", (name, _fixed(term, term.time)), s)]
            self.lags.append((name, _fixed(term, term.time)))
            return [("lag", len(self.lags) - 1, s)]
        raise NotSimulable(f"term {term.name} of kind {term.kind} has no free-run form")


def _model_side(model, reading: _Reading) -> list[tuple[str, Any, float]]:
    """The balance's model side: the model's terms with their coefficients, then the rig's
    known terms (the free-fall friction law as one part)."""
    rig, units = model.rig, model.document["units"]
    rhs: list[tuple[str, Any, float]] = []
    for term, coef in zip(model.terms, model.coef, strict=True):
        rhs += reading.parts(term, float(coef))
    for term in rig.known:
        if getattr(term, "source", None) == "free_fall":
            law = model.document["known"]["free_fall_friction"]
            rhs.append(
                ("friction", (float(law["Fc"]), float(law["b"]), reading.v0), float(term.sign))
            )
        else:
            rhs += reading.parts(term, rig.term_value(term, units))
    return rhs


def _explained_side(model, reading: _Reading) -> list[tuple[str, Any, float]]:
    """The balance's explained side: the motion (mass a + offset), or the explained parts."""
    rig = model.rig
    if rig.motion is not None:
        return [("accel", None, float(rig.motion.mass)), ("const", None, float(rig.motion.offset))]
    lhs: list[tuple[str, Any, float]] = []
    for value, part in zip(rig.part_values(model.document["units"]), rig.explained.parts,
                           strict=True):  # fmt: skip
        powers = part.powers()
        if "a" in powers and powers != {"a": 1}:
            raise NotSimulable(f"the explained part {part.channel} is not linear in a")
        if powers == {"a": 1}:
            lhs.append(("accel", None, float(value)))
        elif not powers:
            lhs.append(("const", None, float(value)))
        else:
            lhs.append(("mono", reading.monomial(powers), float(value)))
    return lhs


def equation(model, v0: float | None = None) -> Equation:
    """The equation of motion of ``model`` (:class:`~hmid.portable.Model`) on its rig."""
    x = model.rig.position
    if x is None:
        raise NotSimulable("the rig declares no position: a free run does not apply")
    fit = model.document.get("fit") or {}
    reading = _Reading(x, float(v0 if v0 is not None else max(fit.get("v_deadband", 0.002), 1e-4)))
    rhs = _model_side(model, reading)
    lhs = _explained_side(model, reading)
    if not any(kind == "accel" for kind, _, _ in (*rhs, *lhs)):
        raise NotSimulable(
            "the balance has no inertial term (no a, no motion): the rig imposes its position, "
            "so a free run does not apply"
        )
    return Equation(tuple(rhs), tuple(lhs), tuple(reading.inputs), len(reading.memory),
                    tuple(reading.lags), reading.v0)  # fmt: skip


#: The floor of the regularisation velocity, as a share of the fit's low-speed cut-off
LEAST_V0 = 1e-3


def free_run_v0(model) -> float:
    """The free run's regularisation velocity: the least v0, at most the fit's low-speed
    cut-off (the :func:`equation`'s default) and at least :data:`LEAST_V0` of it, at which the
    friction's damping near v = 0, (sum of the Coulomb levels) / (mass v0), keeps a step of one
    sample dt within dt Fc / (M v0) <= 2; the cut-off where the file has no sample rate, or the
    balance no Coulomb friction or no mass."""
    eq = equation(model)
    rate = model.document.get("sample_rate_hz")
    levels = sum(abs(c) for kind, scale, c in eq.rhs if kind == "tanh" and scale == eq.v0)
    levels += sum(abs(c * data[0]) for kind, data, c in eq.rhs if kind == "friction")
    mass = abs(sum(c for kind, _, c in eq.lhs if kind == "accel")
               - sum(c for kind, _, c in eq.rhs if kind == "accel"))  # fmt: skip
    if not rate or levels == 0 or mass == 0:
        return eq.v0
    return float(min(eq.v0, max(levels / (2.0 * mass * float(rate)), LEAST_V0 * eq.v0)))
