"""The multi-fibre bionic ankle of thesis Ch. 6: a planar one-degree-of-freedom joint.

The foot turns about the ankle (``theta``, positive in plantarflexion; frame and mounting in
:mod:`~hmid.simulate.rigs.ankle_params`) under

    (I_foot + m_h |h|^2) d omega/dt = sum_i T_i r_i(theta) + tau_g(theta) - c omega - friction

* fibre i (2 gastrocnemius, 3 soleus: active, posterior; 3 tibialis anterior: passive,
  anterior) is a straight line from its origin on the shank to its insertion on the foot; its
  length L_i(theta) and moment arm r_i = -dL_i/dtheta (virtual work) follow from the two points;
* its tension is the simulator's muscle model read as a pull, never a push (a latex tube goes
  slack): T = max(0, s(t) (k1 x + k3 x^3 + q) - A_eff P - F0), x = L_i(theta) - L0_i its
  elongation, dq/dt = -q/tau + k2 dx/dt (q follows the line's length even when slack);
* each active fibre has its own valve (:mod:`hmid.simulate.valves`: on/off inlet and outlet
  solenoids with their opening and closing times, or a proportional valve); the tibialis holds
  no pressure;
* tau_g: the foot's weight and a mass ``m_h`` hung at the heel hook ``h`` (it dorsiflexes: the
  stiffness test's load); c: joint damping; friction: Coulomb at the joint with true stick-slip
  (as in :mod:`hmid.simulate.rigs.hydro_muscle`); end stops at 20 deg dorsiflexion and 40 deg
  plantarflexion (an inelastic stop);
* a potentiometer reads the angle on its ADC's grid (``theta_pot``: what a controller sees).

Effects (:mod:`hmid.simulate.effects`, never declared to a controller's model): ``stiffness(t)``
scales every fibre's springs, ``muscle(t, x, v, P)`` adds a force per fibre (along +x),
``sliding``/``breakaway`` act at the joint, read as torques (N m) of the angular velocity
(rad/s), with P the mean pressure of the active fibres. So ``viscous`` is extra joint damping,
``stribeck`` a breakaway peak, ``stiffness_drift`` a softening latex. ``sense`` hooks do not
reach the potentiometer (its reading is made inside the scan, where a controller reads it).

Symplectic (semi-implicit) Euler with ``substeps`` steps per sample, the Maxwell arms and the
valves advanced exactly over a step; the state logged at the end of each interval.
:func:`hmid.simulate.rig.integrate` and :func:`hmid.simulate.rig.closed_loop` run it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import brentq

from hmid.simulate.effects import Effect
from hmid.simulate.rig import SimulatedRig, Trajectory
from hmid.simulate.rigs.ankle_params import AnkleParams
from hmid.simulate.valves import OnOffValves

#: What an ankle trajectory holds (SI units), in its order; per-fibre signals are (samples,
#: fibres) in :attr:`AnkleParams.fibre_names` order, per-valve ones (samples, active fibres).
SIGNALS = {
    "valves": "valve command per active fibre (on/off: -1 vent .. +1 fill; proportional: Pa)",
    "hung_mass": "mass hung at the heel hook (kg)",
    "theta": "joint angle (rad, + plantarflexion)",
    "omega": "angular velocity (rad/s)",
    "theta_pot": "potentiometer reading of the angle (rad, on its ADC grid)",
    "P": "gauge pressure per active fibre",
    "F": "tension per fibre (N, >= 0)",
    "x": "elongation per fibre (m)",
    "torque": "joint torque of the fibres (N m, + plantarflexion)",
    "contact": "the foot touched an end stop (or was held there) during the interval",
}


class _Plant(NamedTuple):
    """The ankle's numbers as float64 arrays (traced: new values do not recompile)."""

    ox: Any  # fibre origins (shank), per fibre
    oy: Any
    px: Any  # fibre insertions (foot frame), per fibre
    py: Any
    L0: Any  # relaxed length (core + tendon), per fibre
    A: Any
    F0: Any
    k1: Any
    k3: Any
    k2: Any
    tau: Any
    m_f: Any
    I_f: Any
    cx: Any
    cy: Any
    hx: Any
    hy: Any
    damping: Any
    Fc: Any
    static_ratio: Any
    th_min: Any
    th_max: Any
    g: Any
    lsb: Any


class _Valve(eqx.Module):
    """A valve of :mod:`hmid.simulate.valves` inside the scan: its kind static, its numbers
    traced (the valve's own ``step`` runs on them: one home for the valve's physics)."""

    kind: type = eqx.field(static=True)
    fields: dict[str, Any]

    def initial(self, n: int) -> Any:
        return jax.tree.map(lambda a: jnp.full(n, a), self.kind().initial())

    def step(self, state, P, command, dt):
        return self.kind.model_construct(**self.fields).step(state, P, command, dt)


def geometry(theta, ox, oy, px, py, xp: Any = jnp):
    """Each fibre's length L(theta) and moment arm r = -dL/dtheta (m): a straight line from the
    origin (ox, oy) on the shank to the insertion (px, py) on the foot, turned by -theta."""
    c, s = xp.cos(theta), xp.sin(theta)
    dx, dy = ox - (px * c + py * s), oy - (-px * s + py * c)
    L = xp.sqrt(dx * dx + dy * dy)
    return L, (dx * (-px * s + py * c) + dy * (-px * c - py * s)) / L


def _tension(c: _Plant, effects, t, x, v, q, P):
    stiffness = 1.0
    for effect in effects:
        stiffness = stiffness * effect.stiffness(t)
    pull = stiffness * (c.k1 * x + c.k3 * x**3 + q) - c.A * P - c.F0
    for effect in effects:  # a force along +x (elongation) lowers the pull
        pull = pull - effect.muscle(t, x, v, P)
    return jnp.maximum(pull, 0.0)


def _forces(c: _Plant, effects, t, theta, omega, q, P, m_h):
    """Fibre tensions, elongations, the fibres' torque and the applied torque (fibres + weight)."""
    L, r = geometry(theta, c.ox, c.oy, c.px, c.py)
    x = L - c.L0
    P_all = jnp.concatenate([P, jnp.zeros(len(c.L0) - len(P))])
    T = _tension(c, effects, t, x, -r * omega, q, P_all)
    torque = jnp.sum(T * r)
    cos, sin = jnp.cos(theta), jnp.sin(theta)
    weight = c.g * (c.m_f * (c.cx * cos + c.cy * sin) + m_h * (c.hx * cos + c.hy * sin))
    return T, x, r, torque, torque + weight


def _substep(c: _Plant, valve: _Valve, effects, dt, command, m_h, held, state):
    t, th, om, q, P, vs, stuck = state
    vs, P = valve.step(vs, P, command, dt)
    _, _, r, _, tau_app = _forces(c, effects, t, th, om, q, P, m_h)
    inertia = c.I_f + m_h * (c.hx**2 + c.hy**2)
    P_mean = jnp.mean(P)

    def slide(w):
        return jnp.sign(w) * c.Fc + sum(e.sliding(w, P_mean, th) for e in effects)

    F_s = c.Fc * c.static_ratio + sum(e.breakaway(P_mean, th) for e in effects)
    blocked = ((th <= c.th_min) & (tau_app < 0)) | ((th >= c.th_max) & (tau_app > 0))
    breaks = (jnp.abs(tau_app) > F_s) & ~blocked & ~held
    f_start = slide(jnp.sign(tau_app) * 1e-12)
    f_stuck = jnp.where(breaks, f_start, jnp.where(blocked, 0.0, tau_app))
    friction = jnp.where(stuck, f_stuck, slide(om))
    alpha = jnp.where(stuck & ~breaks, 0.0, (tau_app - friction - c.damping * om) / inertia)
    om_new = om + alpha * dt
    # A turning foot whose velocity reaches zero within the step spends the rest of it stuck:
    # it breaks away again only if the applied torque exceeds the breakaway level.
    reversed_ = ~stuck & (om_new * om < 0)
    rest = jnp.where(reversed_, om_new / jnp.where(reversed_, alpha * dt, 1.0), 0.0)
    rebreaks = reversed_ & (jnp.abs(tau_app) > F_s) & ~held
    om_rebound = (tau_app - f_start) / inertia * rest * dt
    om_new = jnp.where(reversed_, jnp.where(rebreaks, om_rebound, 0.0), om_new)
    om_new = jnp.where(held, 0.0, om_new)
    th_new = th + om_new * dt
    contact = (th_new < c.th_min) | (th_new > c.th_max)
    th_new = jnp.clip(th_new, c.th_min, c.th_max)
    om_new = jnp.where(contact, 0.0, om_new)
    stuck_new = jnp.where(stuck, ~breaks, reversed_ & ~rebreaks) | contact | held
    decay = jnp.exp(-dt / c.tau)  # the Maxwell arm, exact for the step's fibre velocity
    q_new = q * decay + c.k2 * c.tau * (1.0 - decay) * (-r * om_new)
    return (t + dt, th_new, om_new, q_new, P, vs, stuck_new), contact | (held & blocked)


def _reading(c: _Plant, effects, state, m_h) -> dict[str, Any]:
    t, th, om, q, P, _, stuck = state
    T, x, _, torque, _ = _forces(c, effects, t, th, om, q, P, m_h)
    pot = jnp.round(th / c.lsb) * c.lsb
    return {"theta": th, "omega": om, "theta_pot": pot, "P": P, "F": T, "x": x,
            "torque": torque, "stuck": stuck}  # fmt: skip


def _sample(params, state, inputs, substeps: int):
    c, valve, effects, dt = params
    command, m_h, held = inputs

    def body(_, carry):
        st, touched = carry
        st, contact = _substep(c, valve, effects, dt, command, m_h, held, st)
        return st, touched | contact

    state, touched = jax.lax.fori_loop(0, substeps, body, (state, jnp.bool_(False)))
    return state, _reading(c, effects, state, m_h) | {"contact": touched}


def free_elongation(muscle, P: float) -> float:
    """Elongation (m) of an unloaded fibre at pressure P: k1 x + k3 x^3 = A_eff P + F0."""
    push = muscle.A_eff * P + muscle.F0
    if push <= 0:
        return 0.0
    return brentq(lambda x: muscle.k1 * x + muscle.k3 * x**3 - push, 0.0, push / muscle.k1,
                  xtol=1e-15)  # fmt: skip


def relaxed_lengths(params: AnkleParams) -> np.ndarray:
    """Each fibre's relaxed length (core + tendon, m) from the mounting rule of
    :mod:`~hmid.simulate.rigs.ankle_params` and the nominal build."""
    th_min, _ = params.theta_range
    out = []
    for name, group in params.groups.items():
        L, _ = geometry(
            th_min if name != "tibialis" else math.radians(group.mount_deg or 0.0),
            *group.origin, *group.insertion, xp=np,
        )  # fmt: skip
        slack = free_elongation(group.spec.params(), params.supply) if name != "tibialis" else 0
        out += [float(L) - slack] * group.count
    return np.array(out)


def plant(params: AnkleParams) -> _Plant:
    """The ankle's numbers as arrays (float64 inside ``jax.enable_x64``)."""
    fibres = [(g.origin, g.insertion) for g in params.groups.values() for _ in range(g.count)]
    muscles = params.muscles()
    per = {k: np.array([getattr(m, k) for m in muscles]) for k in ("A_eff", "F0", "k1", "k3",
                                                                    "k2", "tau")}  # fmt: skip
    th_min, th_max = params.theta_range
    values = _Plant(
        np.array([o[0] for o, _ in fibres]), np.array([o[1] for o, _ in fibres]),
        np.array([i[0] for _, i in fibres]), np.array([i[1] for _, i in fibres]),
        relaxed_lengths(params), per["A_eff"], per["F0"], per["k1"], per["k3"], per["k2"],
        per["tau"], params.foot_mass, params.foot_inertia, *params.foot_com, *params.hook,
        params.damping, params.coulomb, params.static_ratio, th_min, th_max, params.g,
        params.potentiometer.lsb,
    )  # fmt: skip
    return _Plant(*(jnp.asarray(v, dtype=jnp.float64) for v in values))


def statics(
    params: AnkleParams,
    theta: float,
    P: Any,
    hung_mass: float = 0.0,
    effects: tuple[Effect, ...] = (),
) -> dict[str, Any]:
    """The ankle at rest at ``theta`` with pressures ``P`` (per active fibre), Maxwell arms
    relaxed, at t = 0: fibre tensions ``F``, elongations ``x``, moment arms ``r``, the fibres'
    ``torque`` and the ``net`` torque with the weights (N m, + plantarflexion)."""
    with jax.enable_x64(True):
        c = plant(params)
        P = jnp.broadcast_to(jnp.asarray(P, dtype=jnp.float64), (params.n_active,))
        T, x, r, torque, net = _forces(c, tuple(effects), 0.0, jnp.float64(theta), 0.0,
                                       jnp.zeros(params.n_fibres), P, hung_mass)  # fmt: skip
        return {"F": np.asarray(T), "x": np.asarray(x), "r": np.asarray(r),
                "torque": float(torque), "net": float(net)}  # fmt: skip


def equilibrium(
    params: AnkleParams, P: Any, hung_mass: float = 0.0, effects: tuple[Effect, ...] = ()
) -> float:
    """The angle (rad) at which the foot rests with pressures ``P`` and ``hung_mass`` (no
    friction): where the net torque vanishes, or the end stop it pushes against."""
    th_min, th_max = params.theta_range

    def net(theta):
        return statics(params, theta, P, hung_mass, effects)["net"]

    if net(th_max) >= 0:
        return th_max
    if net(th_min) <= 0:
        return th_min
    return brentq(net, th_min, th_max, xtol=1e-13)


@dataclass(frozen=True)
class Ankle(SimulatedRig):
    """The Ch. 6 ankle for :func:`~hmid.simulate.rig.integrate` and
    :func:`~hmid.simulate.rig.closed_loop`.

    Inputs, per sample: ``valves`` (samples, active fibres): each active fibre's valve command
    in :attr:`AnkleParams.fibre_names` order (gastrocnemius 1-2, soleus 1-3): with on/off
    valves +1 fill, 0 hold, -1 vent (between: a PWM duty's mean); with a proportional valve
    the commanded pressure (Pa). Optional: ``hung_mass`` (kg at the heel hook, default 0) and
    ``held`` (the joint clamped: the full-force test's blocked relaxation).

    Starts at rest with pressures ``P0`` (default: the supply where the first on/off command
    fills, else vented; a proportional valve's first command) at ``theta0`` (default: the
    static equilibrium, :func:`equilibrium`), valves shut.
    """

    params: AnkleParams = field(default_factory=AnkleParams)
    effects: tuple[Effect, ...] = ()
    P0: tuple[float, ...] | None = None
    theta0: float | None = None

    name: ClassVar[str] = "ankle"
    inputs: ClassVar[tuple[str, ...]] = ("valves", "hung_mass", "held")
    signals: ClassVar[Mapping[str, str]] = SIGNALS
    first_sample: ClassVar[int] = 1  # the state at the end of each interval
    finite: ClassVar[tuple[str, ...]] = ("theta", "omega", "torque")
    diverged: ClassVar[str] = "check the ankle's inertia, the fibres' stiffness and the substeps"
    sample = staticmethod(_sample)

    def _inputs(self, inputs: Mapping[str, np.ndarray]):
        p = self.params
        command = np.asarray(inputs["valves"], dtype=float)
        if command.ndim != 2 or command.shape[1] != p.n_active:
            raise ValueError(
                f"valves: one column per active fibre {list(p.fibre_names[: p.n_active])}, "
                f"got shape {command.shape}"
            )
        n = len(command)
        hung, held = inputs.get("hung_mass"), inputs.get("held")
        hung = np.zeros(n) if hung is None else np.asarray(hung, dtype=float)
        held = np.zeros(n, dtype=bool) if held is None else np.asarray(held, dtype=bool)
        return command, hung, held

    def _initial(self, command: np.ndarray, hung: np.ndarray):
        p = self.params
        if self.P0 is not None:
            P0 = np.asarray(self.P0, dtype=float)
        elif isinstance(p.valve, OnOffValves):
            P0 = np.where(command[0] > 0, p.supply, 0.0)
        else:
            P0 = command[0].copy()
        theta0 = self.theta0
        if theta0 is None:
            theta0 = equilibrium(p, P0, float(hung[0]), tuple(self.effects))
        valve = _Valve(type(p.valve), {k: jnp.float64(v) for k, v in p.valve})
        init = (
            jnp.float64(0.0), jnp.float64(theta0), jnp.float64(0.0), jnp.zeros(p.n_fibres),
            jnp.asarray(P0, dtype=jnp.float64), valve.initial(p.n_active), jnp.bool_(True),
        )  # fmt: skip
        return valve, init

    def prepare(self, inputs, rate, substeps):
        command, hung, held = self._inputs(inputs)
        valve, init = self._initial(command, hung)
        params = (plant(self.params), valve, tuple(self.effects), 1.0 / (rate * substeps))
        return params, init, (jnp.asarray(command), jnp.asarray(hung), jnp.asarray(held))

    def initial_outputs(
        self, inputs: Mapping[str, np.ndarray], rate: float = 1000.0
    ) -> dict[str, np.ndarray]:
        """The outputs at the initial state: what :func:`~hmid.simulate.rig.closed_loop`'s
        controller reads before the first sample (the state is at rest: ``rate`` plays no
        part)."""
        command, hung, _ = self._inputs(inputs)
        with jax.enable_x64(True):
            _, init = self._initial(command, hung)
            out = _reading(plant(self.params), tuple(self.effects), init, float(hung[0]))
            return {k: np.asarray(v) for k, v in out.items()} | {"contact": np.asarray(False)}

    def trajectory(self, t, rate, inputs, out):
        command, hung, _ = self._inputs(inputs)
        signals = {"valves": command, "hung_mass": hung}
        return Trajectory(t, signals | {k: out[k] for k in list(SIGNALS)[2:]})
