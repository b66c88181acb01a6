"""The multi-fibre ankle of thesis Ch. 6 as a plant: the joint's torque balance inverted.

The ankle (:mod:`hmid.simulate.rigs.ankle`) is an antagonist pair: the rear fibres (2
gastrocnemius, 3 soleus) pull the heel up and a pressure *relaxes* them (a Hydro Muscle
elongates when filled), the passive tibialis pulls the toes up. So the angle is set by the
pressure in the engaged fibres: more pressure, more dorsiflexion (the plant's gain is negative,
and so are the PD's gains). :class:`AnkleRig` adapts it to :class:`~hmid.control.plant.Plant`:

* ``tracked``: the angle as the potentiometer reads it (its 0.29 deg steps; the metrics score
  the true angle);
* ``effort``: one pressure for every engaged fibre; :class:`Recruited` realises it on their
  valves (proportional: the pressure itself; on/off: switched or PWM per fibre on its own
  pressure) and keeps the disengaged fibres filled to the supply, where they go slack (thesis
  Ch. 6: a fibre is disengaged by elongating it more than the others);
* ``demand``: the joint's balance, J a + c w + friction = sum_i r_i(theta) T_i(x_i, v_i, P,
  q_i) + the tibialis's torque + the foot's weight, solved for the one P (affine in P for the
  SLS and the P-linear families): each fibre's tension is its type's identified model read as a
  pull (T = -F_m), at the elongation the geometry gives; the joint (inertia, damping, Coulomb
  friction smoothed, the weight, the mounting) and the passive tibialis (its build) are the
  known mechanics, as the Ch. 4 rig's masses are for :class:`~hmid.control.plant.MuscleRig`;
* ``linear``: the same balance linearised at the reference's start (angle, rate, the fibres'
  Maxwell arms, the valve's lag) for the tuning rule.

:func:`recruit` chooses the engaged fibres for a demanded torque and stiffness: the fewest whose
full torque and joint stiffness (vented, by the identified models) reach them over the task's
angles (the thesis varies the ankle's stiffness by recruitment).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from hmid.control.actuation import Actuation, Proportional
from hmid.control.inverse import ForceLaw, lead
from hmid.control.plant import lagged
from hmid.control.references import Reference
from hmid.simulate.effects import Effect
from hmid.simulate.params import FrictionParams, MuscleParams, RigParams
from hmid.simulate.rig import Trajectory
from hmid.simulate.rigs.ankle import Ankle, geometry, relaxed_lengths
from hmid.simulate.rigs.ankle_params import AnkleParams
from hmid.simulate.valves import OnOffValves, ProportionalValve

V0 = 0.01  # rad/s: the joint's Coulomb friction as tanh(w / V0) in the model (a smooth sign)


def muscle_law(muscle: MuscleParams, name: str = "build") -> ForceLaw:
    """A fibre's own physics as a model (its tension is -force): the perfect model."""
    rig = RigParams(muscle=muscle, friction=FrictionParams(F_block=0.0, F_pulley=0.0))
    return replace(ForceLaw.of_rig(rig), name=name)


@dataclass(frozen=True)
class FibreLaws:
    """The controller's model of every fibre, in :attr:`AnkleParams.fibre_names` order: the
    active ones from their type's identified model, the passive tibialis from its build."""

    laws: tuple[ForceLaw, ...]
    name: str

    @classmethod
    def of(cls, params: AnkleParams, models: Mapping[str, Any]) -> FibreLaws:
        """From loaded models (:class:`hmid.Model`) by fibre type (gastrocnemius, soleus)."""
        laws = [ForceLaw.of(models[name]) for name in ("gastrocnemius", "soleus")]
        tib = muscle_law(params.tibialis.spec.params(), "tibialis build")
        out = ((laws[0],) * params.gastrocnemius.count + (laws[1],) * params.soleus.count
               + (tib,) * params.tibialis.count)  # fmt: skip
        named = ", ".join(f"{k} {models[k].name}" for k in ("gastrocnemius", "soleus"))
        return cls(out, named)

    @classmethod
    def perfect(cls, params: AnkleParams) -> FibreLaws:
        """Every fibre's own physics (the plant's muscles): the perfect model."""
        return cls(tuple(muscle_law(m) for m in params.muscles()), "the plant's physics")


def _frame(params: AnkleParams) -> tuple[np.ndarray, ...]:
    pts = [(g.origin, g.insertion) for g in params.groups.values() for _ in range(g.count)]
    ox, oy = np.array([o[0] for o, _ in pts]), np.array([o[1] for o, _ in pts])
    px, py = np.array([i[0] for _, i in pts]), np.array([i[1] for _, i in pts])
    return ox, oy, px, py, relaxed_lengths(params)


def kinematics(params: AnkleParams, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elongation x and moment arm r (samples, fibres) along the angles ``theta``."""
    ox, oy, px, py, L0 = _frame(params)
    L, r = geometry(np.asarray(theta, dtype=float)[:, None], ox, oy, px, py, xp=np)
    return L - L0, r


def _tensions(laws: FibreLaws, t, x, v) -> list[list[np.ndarray]]:
    """Each fibre's polynomial in P of its tension (T = -F_m), along x(t) of every fibre."""
    out = []
    for i, law in enumerate(laws.laws):
        memory = law.memory(t, x[:, i])
        out.append([-c for c in law.coefficients(x[:, i], v[:, i], memory)])
    return out


class Recruited(eqx.Module):
    """One effort realised on the engaged fibres' valves (``inner`` per fibre, on its own
    pressure); the disengaged ones get ``idle`` (+1: filled, or the supply pressure)."""

    inner: Actuation
    engaged: Any  # bool per active fibre
    idle: Any

    def init(self) -> Any:
        n = self.engaged.shape[0]
        return jax.tree.map(lambda a: jnp.broadcast_to(a, (n,)), self.inner.init())

    def realise(self, state: Any, effort: Any, measured: Any) -> tuple[Any, dict]:
        state, out = self.inner.realise(state, effort, measured)
        key = self.inner.command if isinstance(self.inner, Proportional) else self.inner.valve
        command = jnp.broadcast_to(out[key], self.engaged.shape)
        return state, {"valves": jnp.where(self.engaged, command, self.idle)}


@dataclass(frozen=True)
class AnkleRig:
    """The Ch. 6 ankle as a plant (see the module's docstring): ``engaged`` per active fibre,
    the valves those of ``params`` (proportional or on/off), ``realisation`` how an effort
    reaches one fibre's valve."""

    params: AnkleParams
    engaged: tuple[bool, ...]
    effects: tuple[Effect, ...] = ()
    realisation: Actuation = field(default_factory=Proportional)
    rate: float = 1000.0
    noise: float = 0.0
    substeps: int = 10
    sensor_step: float | None = None  # None: the potentiometer's; 0: exact
    task: str = "angle"
    tracked: str = "theta"
    unit: str = "rad"

    def __post_init__(self) -> None:
        if len(self.engaged) != self.params.n_active or not any(self.engaged):
            raise ValueError(f"engaged: one flag per active fibre, at least one; got "
                             f"{self.engaged}")  # fmt: skip

    @property
    def resolution(self) -> float:
        return self.params.potentiometer.lsb if self.sensor_step is None else self.sensor_step

    @property
    def on_off(self) -> bool:
        return isinstance(self.params.valve, OnOffValves)

    @property
    def actuation(self) -> Recruited:
        idle = 1.0 if self.on_off else self.params.supply
        mask = jnp.asarray(np.array(self.engaged))
        return Recruited(self.realisation, mask, jnp.asarray(idle))

    @property
    def limits(self) -> tuple[float, float]:
        """(lowest, highest) pressure in a fibre: vented to the supply."""
        return 0.0, float(self.params.supply)

    def pressures(self, effort: float) -> tuple[float, ...]:
        """Per active fibre: the effort if engaged, the supply (slack) if not."""
        return tuple(float(effort) if e else self.params.supply for e in self.engaged)

    def rig(self, effort0: float = 0.0) -> Ankle:
        return Ankle(self.params, self.effects, P0=self.pressures(effort0))

    def inputs(self, n: int, effort0: float) -> dict[str, np.ndarray]:
        row = (np.where(self.engaged, 0.0, 1.0) if self.on_off
               else np.array(self.pressures(effort0)))  # fmt: skip
        return {"valves": np.tile(row, (n, 1))}

    def outputs(self, effort0: float) -> dict[str, Any]:
        return self.rig(effort0).initial_outputs(self.inputs(2, effort0), self.rate)

    def commanded(self, traj: Trajectory, commands: Mapping[str, np.ndarray], ff: Any):
        """(effort, the engaged fibres' mean pressure, the engaged on/off valves' commands)."""
        mask = np.array(self.engaged)
        valves = commands["valves"]
        effort = ff.commands if self.on_off else valves[:, int(np.argmax(mask))]
        return effort, traj.P[:, mask].mean(axis=1), valves[:, mask] if self.on_off else None

    # --- the model's side ----------------------------------------------------------------
    def _balance(self, laws: FibreLaws, ref: Reference) -> tuple[np.ndarray, list, list]:
        """The torque the engaged fibres must give along ``ref``, and per engaged fibre its
        moment arm and its tension's polynomial in P (coefficient arrays), the rest of the
        balance known."""
        p = self.params
        x, r = kinematics(p, ref.y)
        v = -r * ref.dy[:, None]
        polys = _tensions(laws, ref.t, x, v)
        tib = slice(p.n_active, p.n_fibres)
        passive = sum(r[:, i] * np.maximum(polys[i][0], 0.0)
                      for i in range(tib.start, tib.stop))  # fmt: skip
        (cx, cy), th = p.foot_com, ref.y
        weight = p.g * p.foot_mass * (cx * np.cos(th) + cy * np.sin(th))
        need = (p.foot_inertia * ref.ddy + p.damping * ref.dy + p.coulomb * np.tanh(ref.dy / V0)
                - passive - weight)  # fmt: skip
        engaged = [i for i, e in enumerate(self.engaged) if e]
        return need, [r[:, i] for i in engaged], [polys[i] for i in engaged]

    def demand(self, law: FibreLaws, ref: Reference) -> np.ndarray:
        """The pressure in the engaged fibres that moves the foot along ``ref`` (rad).

        A fibre pulls, never pushes (the rig's tension is max(0, ...)): where the one pressure
        leaves an engaged fibre's tension negative by its law (fibres unlike each other, e.g.
        each its own build's model: one pressure cannot keep them all taut), the balance is
        solved again without it. Dropping a slack fibre moves the pressure the way that keeps
        it slack (every engaged fibre relaxes with P), so the taut set only shrinks: at most one
        pass per fibre. With one model per type every fibre of a type is alike and taut along
        the task's references: the first solution stands."""
        need, arms, polys = self._balance(law, ref)
        taut = np.ones((len(arms), len(need)), dtype=bool)
        P = _solve(need, arms, polys, taut)
        for _ in arms:
            tension = np.array([sum(c * P**k for k, c in enumerate(poly)) for poly in polys])
            slack = taut & (tension < 0)
            if not slack.any():
                break
            taut &= ~slack
            P = np.where(taut.any(axis=0), _solve(need, arms, polys, taut), P)
        return P

    def feedforward(self, law: FibreLaws, ref: Reference, valve_tau: float) -> np.ndarray:
        P = self.demand(law, ref)
        return P[:-1] if self.on_off else lead(P, valve_tau, 1.0 / self.rate)

    def hold(self, law: FibreLaws, ref: Reference) -> float:
        start = replace(ref, t=ref.t[:2], y=np.full(2, ref.y[0]), dy=np.zeros(2),
                        ddy=np.zeros(2))  # fmt: skip
        return float(self.demand(law, start)[0])

    def linear(self, law: FibreLaws, ref: Reference, valve_tau: float) -> Any:
        """The ankle linearised at the reference's start (``control.StateSpace``: effort ->
        angle): theta, omega, each taut fibre's Maxwell arms, the valve's lag."""
        return linearise(self, law, float(ref.y[0]), self.hold(law, ref), valve_tau)

    # --- other plants ---------------------------------------------------------------------
    def with_fibres(self, fibres: Sequence[MuscleParams]) -> AnkleRig:
        return replace(self, params=self.params.model_copy(update={"fibres": tuple(fibres)}))

    def with_effects(self, effects: tuple[Effect, ...]) -> AnkleRig:
        return replace(self, effects=tuple(effects))

    def with_on_off(self, valves: OnOffValves, actuation: Actuation) -> AnkleRig:
        return replace(self, params=self.params.model_copy(update={"valve": valves}),
                       realisation=actuation)  # fmt: skip

    def proportional(self, valve: ProportionalValve) -> AnkleRig:
        return replace(self, params=self.params.model_copy(update={"valve": valve}),
                       realisation=Proportional(highest=self.params.supply))  # fmt: skip


def _solve(need: np.ndarray, arms: list, polys: list, taut: np.ndarray) -> np.ndarray:
    """P where the ``taut`` fibres' torque sum(r_i T_i(P)) meets ``need`` (per sample): exact
    for a balance affine in P, Newton on a polynomial."""
    order = max(len(poly) for poly in polys)
    coefs = [sum(np.where(on, r * poly[k], 0.0) if not on.all() else r * poly[k]
                 for r, poly, on in zip(arms, polys, taut, strict=True) if k < len(poly))
             for k in range(order)]  # fmt: skip
    with np.errstate(divide="ignore", invalid="ignore"):  # no taut fibre: the caller keeps P
        P = (need - coefs[0]) / coefs[1]
    for _ in range(20 if len(coefs) > 2 else 0):  # Newton on a polynomial in P
        value = sum(c * P**k for k, c in enumerate(coefs)) - need
        deriv = sum(k * c * P ** (k - 1) for k, c in enumerate(coefs) if k)
        P = P - value / np.where(deriv == 0, 1.0, deriv)
    return P


def linearise(plant: AnkleRig, laws: FibreLaws, theta0: float, P0: float, valve_tau: float):
    """The balance's Jacobian at rest at ``theta0`` with ``P0`` in the engaged fibres."""

    p = plant.params
    arms = [(i, data[0], data[1], c) for i, law in enumerate(laws.laws)
            for kind, data, c in law.eq.rhs if kind == "memory"]  # fmt: skip
    pressures = np.r_[plant.pressures(P0), np.zeros(p.n_fibres - p.n_active)]

    def torque(theta: float, P: float) -> float:
        Ps = np.where(np.r_[plant.engaged, [False] * (p.n_fibres - p.n_active)], P, pressures)
        x, r = kinematics(p, np.array([theta]))
        total = 0.0
        for i, law in enumerate(laws.laws):
            zero = np.zeros((law.eq.n_memory, 1))
            tension = -law.force(x[:, i], np.zeros(1), Ps[i], zero)
            total += float(r[0, i] * max(float(tension[0]), 0.0))
        (cx, cy) = p.foot_com
        return total + p.g * p.foot_mass * (cx * np.cos(theta) + cy * np.sin(theta))

    h = 1e-6
    d_theta = (torque(theta0 + h, P0) - torque(theta0 - h, P0)) / (2 * h)
    d_P = (torque(theta0, P0 + 10.0) - torque(theta0, P0 - 10.0)) / 20.0
    x0, r0 = kinematics(p, np.array([theta0]))
    taut = [-laws.laws[i].force(x0[:, i], np.zeros(1), pressures[i],
                                np.zeros((laws.laws[i].eq.n_memory, 1)))[0] > 0
            for i in range(p.n_fibres)]  # fmt: skip
    # the taut fibres' Maxwell arms act as one arm: Q = sum r_i k2_i q_i (a torque) relaxing at
    # their stiffness-weighted relaxation time, driven by sum r_i^2 k2_i (exact where the times
    # agree, as one build's fibres' do; python-control's transfer functions do not survive
    # eight near-repeated poles)
    weights = [(float(r0[0, i]) ** 2 * -c, tau) for i, _, tau, c in arms if taut[i]]
    total = sum(w for w, _ in weights)
    lumped = {sum(w * tau for w, tau in weights) / total: total} if total > 0 else {}
    n = 3 + len(lumped)  # theta, omega, the lumped arms, P
    J = p.foot_inertia
    A = np.zeros((n, n))
    A[0, 1] = 1.0
    A[1, 0], A[1, 1], A[1, n - 1] = d_theta / J, -p.damping / J, d_P / J
    for j, (tau, stiffness) in enumerate(lumped.items()):
        A[1, 2 + j] = 1 / J
        A[2 + j, 2 + j], A[2 + j, 1] = -1 / tau, -stiffness
    return lagged(A, valve_tau)


def full_torque(plant: AnkleRig, laws: FibreLaws, engaged: Sequence[int], theta) -> np.ndarray:
    """The torque (N m, + plantarflexion) the ``engaged`` fibres give vented (P = 0), by the
    models, at the angles ``theta`` (at rest)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    x, r = kinematics(plant.params, theta)
    total = np.zeros_like(theta)
    for i in engaged:
        law = laws.laws[i]
        zero = np.zeros((law.eq.n_memory, len(theta)))
        total += r[:, i] * np.maximum(-law.force(x[:, i], np.zeros_like(theta), 0.0, zero), 0)
    return total


def joint_stiffness(
    plant: AnkleRig, laws: FibreLaws, engaged: Sequence[int], theta, h: float = 1e-4
) -> np.ndarray:
    """The joint's rotational stiffness (N m/rad) with the ``engaged`` fibres vented, by the
    models, at rest at the angles ``theta``: -d torque / d theta, the passive tibialis in."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    fibres = (*engaged, *range(plant.params.n_active, plant.params.n_fibres))
    up, down = (full_torque(plant, laws, fibres, theta + d) for d in (h, -h))
    return -(up - down) / (2 * h)


def recruit(
    plant: AnkleRig, laws: FibreLaws, torque: float, theta, stiffness: float = 0.0
) -> tuple[bool, ...]:
    """The fewest active fibres whose full torque (vented, by the models) reaches ``torque``
    (N m) and whose joint stiffness reaches ``stiffness`` (N m/rad) at every angle of
    ``theta``; of equal counts the strongest. ValueError if all together cannot."""
    n = plant.params.n_active

    def margin(fibres) -> float:
        reach = full_torque(plant, laws, fibres, theta).min() - torque
        stiff = joint_stiffness(plant, laws, fibres, theta).min() - stiffness
        return min(reach / max(abs(torque), 1.0), stiff / max(stiffness, 1.0))

    for count in range(1, n + 1):
        best = max(itertools.combinations(range(n), count), key=margin)
        if margin(best) >= 0:
            return tuple(i in best for i in range(n))
    reach = full_torque(plant, laws, range(n), theta).min()
    stiff = joint_stiffness(plant, laws, range(n), theta).min()
    raise ValueError(f"a torque of {torque} N m and a stiffness of {stiffness} N m/rad are beyond "
                     f"every fibre together ({reach:.3g} N m, {stiff:.3g} N m/rad over the "
                     "task's angles)")  # fmt: skip
