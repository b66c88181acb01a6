"""The Hydro Muscle rig of thesis Ch. 4: block M and hanging mass m1 moved by the muscle (eq. 4.1).

Motion along the rail obeys  (M + m1) a = F_m - m1 g - f,  where f is rail + pulley friction.
Friction follows a stick-slip (Karnopp-style) law, so the block stops and stays stopped while the
applied force is below the breakaway level, and never chatters through zero velocity:

* stuck: the block stays at rest while |F_m - m1 g| <= F_s; above it, it starts to slide against the
  friction level at v = 0+ in the direction of the applied force;
* sliding: a = (F_app - f(v)) / (M + m1); if the velocity reaches zero within a step, the rest of
  the step is treated as stuck: the block stays at rest, or breaks away in the direction of the
  applied force if that exceeds the breakaway level.

Semi-implicit Euler with ``substeps`` steps per sample; the Maxwell arm's force q is advanced
exactly for constant velocity over a step. Effects (:mod:`hmid.simulate.effects`) add friction,
scale the latex's springs or add muscle forces (a dashpot: explicit, at the step's start
velocity). Accelerations and forces are logged from the last substep before each sample instant
(a sample-and-hold reading, time-aligned to within one substep), so F_m - m1 g - friction =
(M + m1) a holds exactly at every logged sample. The pressure follows the command through the
valve's slew-limited first-order lag; or, with ``valves`` set (:class:`~hmid.simulate.valves.
OnOffValves`, for control), the input ``valve`` opens an inlet (+1) or an outlet (-1) solenoid
valve and ``P_cmd`` only sets the starting pressure. :func:`hmid.simulate.rig.integrate` runs the
loop: a 60 s log at 1 kHz with 20 substeps takes well under a second after compilation.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import brentq

from hmid.errors import SimulationError
from hmid.simulate.effects import Effect
from hmid.simulate.params import RigParams
from hmid.simulate.rig import SimulatedRig, Trajectory
from hmid.simulate.valves import OnOffValves, fill_vent


class _Constants(NamedTuple):
    """Rig parameters as a pytree of floats (traced, so new values do not recompile)."""

    A_eff: float
    F0: float
    k1: float
    k3: float
    k2: float
    tau: float
    Fc: float
    static_ratio: float
    M: float
    m1: float
    g: float
    x_min: float
    x_max: float
    valve_tau: float
    slew: float
    connected: float  # 1.0 with the muscle attached, 0.0 for free-fall tests


#: What a Hydro Muscle trajectory holds (SI units), in its order.
SIGNALS = {
    "P_cmd": "commanded gauge pressure",
    "P": "true gauge pressure in the muscle",
    "x": "block position (muscle elongation)",
    "v": "block velocity",
    "a": "acceleration at the sample instant",
    "F_m": "muscle force at the sample instant",
    "friction": "friction force at the sample instant (signed, along +x)",
    "q": "Maxwell-arm force",
    "stuck": "block at rest at the sample instant",
    "contact": "block touched an end stop (or was held there) during the interval",
    "tension_min": "least string tension m1 (g + a) within the interval",
}


def _constants(rig: RigParams, connected: bool) -> _Constants:
    m, f, vlv = rig.muscle, rig.friction, rig.valve
    return _Constants(
        m.A_eff, m.F0, m.k1, m.k3, m.k2, m.tau, f.coulomb, f.static_ratio, rig.M, rig.m1, rig.g,
        rig.x_min, rig.x_max, vlv.tau, vlv.slew, 1.0 if connected else 0.0,
    )  # fmt: skip


def _muscle_force(c: _Constants, effects, t, x, v, q, P):
    stiffness = 1.0
    for effect in effects:
        stiffness = stiffness * effect.stiffness(t)
    force = c.A_eff * P + c.F0 - stiffness * (c.k1 * x + c.k3 * x**3 + q)
    for effect in effects:  # forces beside the latex's springs (a dashpot), at the step's start
        force = force + effect.muscle(t, x, v, P)
    return c.connected * force


class _OnOff(NamedTuple):
    """On/off valves' numbers as a pytree (traced): the fields of OnOffValves."""

    supply: float
    opening_time: float
    closing_time: float
    line_tau: float


def _substep(c: _Constants, effects, dt, held, P_cmd, state, valve=None, command=0.0):
    t, x, v, q, P, stuck = state[:6]
    if valve is None:
        # exact first-order step (stable for any tau), then the valve's flow limit
        target = P_cmd + (P - P_cmd) * jnp.exp(-dt / c.valve_tau)
        P = P + jnp.clip(target - P, -c.slew * dt, c.slew * dt)
        extra: tuple = ()
    else:  # inlet and outlet solenoids: the openings are state
        openings, P = fill_vent(valve, state[6], P, command, dt)
        extra = (openings,)
    F_app = _muscle_force(c, effects, t, x, v, q, P) - c.m1 * c.g
    mass = c.M + c.m1

    def slide_force(vel):
        return jnp.sign(vel) * c.Fc + sum(e.sliding(vel, P, x) for e in effects)

    F_s = c.Fc * c.static_ratio + sum(e.breakaway(P, x) for e in effects)
    blocked = ((x <= c.x_min) & (F_app < 0)) | ((x >= c.x_max) & (F_app > 0))
    breaks = (jnp.abs(F_app) > F_s) & ~blocked & ~held
    f_start = slide_force(jnp.sign(F_app) * 1e-12)
    f_stuck = jnp.where(breaks, f_start, jnp.where(blocked, 0.0, F_app))
    friction = jnp.where(stuck, f_stuck, slide_force(v))
    a = jnp.where(stuck & ~breaks, 0.0, (F_app - friction) / mass)

    v_new = v + a * dt
    # A sliding block that reaches v = 0 within the step spends the rest of it as a stuck block:
    # it breaks away again only if the applied force exceeds the breakaway level.
    reversed_ = ~stuck & (v_new * v < 0)
    rest = jnp.where(reversed_, v_new / jnp.where(reversed_, a * dt, 1.0), 0.0)  # in (0, 1)
    rebreaks = reversed_ & (jnp.abs(F_app) > F_s) & ~held
    v_rebound = (F_app - f_start) / mass * rest * dt
    v_new = jnp.where(reversed_, jnp.where(rebreaks, v_rebound, 0.0), v_new)
    v_new = jnp.where(held, 0.0, v_new)
    x_new = x + v_new * dt
    contact = (x_new < c.x_min) | (x_new > c.x_max)
    x_new = jnp.clip(x_new, c.x_min, c.x_max)
    v_new = jnp.where(contact, 0.0, v_new)
    stuck_new = jnp.where(stuck, ~breaks, reversed_ & ~rebreaks) | contact | held

    decay = jnp.exp(-dt / c.tau)
    q_new = q * decay + c.k2 * c.tau * (1.0 - decay) * v_new
    a_eff = (v_new - v) / dt
    f_eff = jnp.where(contact | blocked, friction, F_app - mass * a_eff)
    tension = jnp.where(contact, jnp.inf, c.m1 * (c.g + a_eff))
    F_m = F_app + c.m1 * c.g
    return (t + dt, x_new, v_new, q_new, P, stuck_new, *extra), (
        a_eff,
        f_eff,
        F_m,
        contact | blocked,
        tension,
    )


def _reading(c: _Constants, effects, state):
    """Acceleration, friction and muscle force *at* the sample instant, from the state the
    sample logs: forces of the last substep's start would lag the logged position by a
    substep, which identification reads as negative damping (stiffness x 50 us)."""
    t, x, v, q, P, stuck = state[:6]
    F_app = _muscle_force(c, effects, t, x, v, q, P) - c.m1 * c.g
    sliding = jnp.sign(v) * c.Fc + sum(e.sliding(v, P, x) for e in effects)
    at_stop = ((x <= c.x_min) & (F_app < 0)) | ((x >= c.x_max) & (F_app > 0))
    # stuck: static friction (or an end stop) holds the applied force
    friction = jnp.where(stuck, jnp.where(at_stop, 0.0, F_app), sliding)
    a = jnp.where(stuck, 0.0, (F_app - sliding) / (c.M + c.m1))
    return a, friction, F_app + c.m1 * c.g


def _sample(params, state, inputs, substeps: int):
    c, effects, dt, valve = params
    P_c, hold, command = inputs

    def body(_, carry):
        st, _, touched, t_min = carry
        st, (a, f, F_m, contact, tension) = _substep(c, effects, dt, hold, P_c, st, valve,
                                                     command)  # fmt: skip
        return st, (a, f, F_m), touched | contact, jnp.minimum(t_min, tension)

    zero = jnp.zeros(())
    state, _, touched, t_min = jax.lax.fori_loop(
        0, substeps, body, (state, (zero, zero, zero), False, jnp.inf)
    )
    a, f, F_m = _reading(c, effects, state)
    _, x, v, q, P, stuck = state[:6]
    out = {"P": P, "x": x, "v": v, "a": a, "F_m": F_m, "friction": f, "q": q, "stuck": stuck}
    return state, out | {"contact": touched, "tension_min": t_min}


def equilibrium(rig: RigParams, P: float, effects: tuple[Effect, ...] = ()) -> float:
    """Elongation at which the muscle holds the hanging weight at pressure P (no friction)."""
    m = rig.muscle
    stiffness = float(np.prod([float(e.stiffness(0.0)) for e in effects])) if effects else 1.0

    def residual(x):
        force = m.A_eff * P + m.F0 - stiffness * (m.k1 * x + m.k3 * x**3)
        for effect in effects:  # at rest: a dashpot adds nothing
            force = force + float(effect.muscle(0.0, x, 0.0, P))
        return force - rig.m1 * rig.g

    if residual(rig.x_min) <= 0:
        return rig.x_min
    if residual(rig.x_max) >= 0:
        return rig.x_max
    return brentq(residual, rig.x_min, rig.x_max, xtol=1e-15)


@dataclass(frozen=True)
class HydroMuscle(SimulatedRig):
    """The Ch. 4 rig for :func:`~hmid.simulate.rig.integrate`: inputs ``P_cmd`` (Pa, held over
    each sample) and optionally ``held`` (the block clamped during sample k: free-fall release)
    and ``valve`` (with ``valves`` set: the on/off valves' command in [-1, 1]; P_cmd[0] is then
    the starting pressure, the rest of P_cmd is recorded, not used).

    Starts at rest with P = P_cmd[0] and, for a connected muscle, at the static equilibrium
    unless ``x0`` is given (without the muscle, at ``x_min``). Raises :class:`SimulationError`
    if the string would go slack (a < -g), where eq. 4.1 fails.
    """

    params: RigParams
    effects: tuple[Effect, ...] = ()
    connected: bool = True
    x0: float | None = None
    valves: OnOffValves | None = None  # None: the rig's proportional valve (params.valve)

    name: ClassVar[str] = "Hydro Muscle"
    inputs: ClassVar[tuple[str, ...]] = ("P_cmd", "held", "valve")
    signals: ClassVar[Mapping[str, str]] = SIGNALS
    first_sample: ClassVar[int] = 1  # the state at the end of each interval
    finite: ClassVar[tuple[str, ...]] = ("x", "v", "P", "F_m")
    diverged: ClassVar[str] = "check the rig parameters (stiffness, masses) and the substeps"
    sample = staticmethod(_sample)

    def prepare(self, inputs, rate, substeps):
        rig, effects = self.params, tuple(self.effects)
        P_cmd = np.asarray(inputs["P_cmd"], dtype=float)
        held = inputs.get("held")
        held = np.zeros(len(P_cmd), dtype=bool) if held is None else np.asarray(held, dtype=bool)
        command = np.asarray(inputs.get("valve", np.zeros(len(P_cmd))), dtype=float)
        x0 = self.x0
        if x0 is None:
            x0 = equilibrium(rig, float(P_cmd[0]), effects) if self.connected else rig.x_min
        init = (
            jnp.float64(0.0), jnp.float64(x0), jnp.float64(0.0), jnp.float64(0.0),
            jnp.float64(P_cmd[0]), jnp.bool_(True),
        )  # fmt: skip
        dt = 1.0 / (rate * substeps)
        valve = None
        if self.valves is not None:
            v = self.valves
            valve = _OnOff(v.supply, v.opening_time, v.closing_time, v.line_tau)
            init = (*init, (jnp.float64(0.0), jnp.float64(0.0)))  # both valves shut
        params = (_constants(rig, self.connected), effects, dt, valve)
        return params, init, (jnp.asarray(P_cmd), jnp.asarray(held), jnp.asarray(command))

    def initial_outputs(self, inputs: Mapping[str, np.ndarray], rate: float) -> dict[str, float]:
        """The outputs a sample would log for the initial state: what a controller reads before
        the first sample of a closed loop (:func:`~hmid.simulate.rig.closed_loop`)."""
        with jax.enable_x64(True):
            params, init, _ = self.prepare(inputs, rate, 1)
            a, friction, F_m = _reading(params[0], params[1], init)
        _, x, v, q, P, stuck = init[:6]
        values = {"P": P, "x": x, "v": v, "a": a, "F_m": F_m, "friction": friction, "q": q}
        return {k: float(v) for k, v in values.items()} | {
            "stuck": bool(stuck),
            "contact": False,
            "tension_min": float(self.params.m1 * self.params.g),
        }

    def trajectory(self, t, rate, inputs, out):
        slack = np.flatnonzero(out["tension_min"] < 0)
        if slack.size:
            raise SimulationError(
                f"the string to the hanging mass goes slack at t = {t[slack[0]]:.4f} s (a < -g): "
                "eq. 4.1 no longer holds; command gentler pressure changes or lower valve.slew"
            )
        P_cmd = np.asarray(inputs["P_cmd"], dtype=float)
        return Trajectory(t, {"P_cmd": P_cmd} | {k: out[k] for k in list(SIGNALS)[1:]})
