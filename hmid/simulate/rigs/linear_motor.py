"""The linear-motor rig: a positioning stage under a digital PD position loop.

A mass M on a linear guide; the motor force u drives it along x (m, v = dx/dt, a = dv/dt). While
the stage slides, the motor force balances

    u = M a + Fv(v) v + Fc(x) sign(v) + offset

so ``offset`` is the force the motor must supply to hold the stage at rest (a cable carrier, a
slight tilt), and F_app = u - offset is the net force that accelerates the stage against friction.
Friction is stick-slip (Karnopp-style, as in :mod:`hmid.simulate.rigs.hydro_muscle`):

* stuck: the stage stays exactly still while |F_app| <= Fs = Fc(x) static_ratio; above it, it
  starts to slide against the Coulomb level in the direction of F_app;
* sliding: a = (F_app - Fv(v) v - Fc(x) sign(v)) / M; a stage whose velocity reaches zero within a
  substep spends the rest of it stuck and breaks away again only if |F_app| > Fs, so it never
  chatters through v = 0.

Optional effects (off by default): ``Fv_negative`` is the viscous coefficient for v < 0 (Fv applies
for v > 0), and ``Fc_slope`` makes Coulomb friction grow along the guide, Fc(x) = max(Fc +
Fc_slope (x - x_centre), 0).

The controller runs at the logging rate with a zero-order hold: at t_k it reads the encoder
(position rounded to ``encoder_step``), and applies u[k] = Kp e[k] + Kd d[k] over [t_k, t_k+1),
with e = r - x_meas and d a first-order low-pass of the backward difference of e. ``substeps``
steps per sample (run by :func:`hmid.simulate.rig.integrate`), each the trapezoid in the position
and in the viscous force (so position and forces stay aligned in time: an explicit step would lag
them by half a substep, which identification reads as a mass and a viscous error); a 30 s log at
1 kHz with 20 substeps takes ~0.05 s after compilation (~0.3 s, once per log length).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from pydantic import Field

from hmid.config import NonNegative, Positive
from hmid.simulate.params import _Frozen
from hmid.simulate.rig import SimulatedRig, Trajectory


class LinearMotorParams(_Frozen):
    """The stage's mass, friction and offset force (SI units), with the optional effects."""

    M: Positive = 95.0  # kg, carriage + payload
    Fv: NonNegative = 200.0  # N s/m, viscous friction (for v > 0 when Fv_negative is set)
    Fc: NonNegative = 20.0  # N, Coulomb friction
    offset: float = -3.0  # N, force the motor supplies at rest
    static_ratio: Annotated[float, Field(ge=1.0)] = 1.0  # breakaway / Coulomb level
    Fv_negative: NonNegative | None = None  # N s/m for v < 0; None: the same as Fv
    Fc_slope: float = 0.0  # N/m, growth of the Coulomb level along the guide
    x_centre: float = 0.0  # m, where Fc(x) = Fc

    @property
    def Fv_neg(self) -> float:
        return self.Fv if self.Fv_negative is None else self.Fv_negative

    def coulomb(self, x: np.ndarray) -> np.ndarray:
        """The Coulomb level Fc(x) >= 0 at positions ``x``."""
        return np.maximum(self.Fc + self.Fc_slope * (np.asarray(x) - self.x_centre), 0.0)

    def friction(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Sliding friction Fv(v) v + Fc(x) sign(v) (signed, along +x)."""
        v = np.asarray(v)
        return np.where(v > 0, self.Fv, self.Fv_neg) * v + self.coulomb(x) * np.sign(v)

    def effects(self) -> list[dict[str, Any]]:
        """The optional effects switched on, for the ground-truth record."""
        out: list[dict[str, Any]] = []
        if self.Fv_negative is not None and self.Fv_negative != self.Fv:
            out.append(
                {"kind": "direction_viscous", "Fv_positive": self.Fv, "Fv_negative": self.Fv_neg}
            )
        if self.Fc_slope != 0.0:
            out.append(
                {"kind": "position_coulomb", "Fc_slope": self.Fc_slope, "x_centre": self.x_centre}
            )
        return out


class PDController(_Frozen):
    """Digital PD position loop; the defaults close it at ~10 Hz with damping ~0.7 for 95 kg.

    Kp = M (2 pi 10 Hz)^2, Kd = 2 0.7 (2 pi 10 Hz) M - Fv. The derivative's low-pass keeps the
    encoder's one-count steps (1 um in 1 ms) to a few newtons of force.
    """

    Kp: Positive = 3.75e5  # N/m
    Kd: NonNegative = 8.0e3  # N s/m
    derivative_cutoff_hz: Positive = 150.0


#: What a linear-motor trajectory holds at t_k = k / rate (SI units), in its order.
SIGNALS = {
    "r": "reference position",
    "x": "true position",
    "v": "true velocity",
    "a": "(v[k+1] - v[k-1]) / (2 dt): mean acceleration over t_k +- dt",
    "x_meas": "encoder reading (what the controller used)",
    "u": "command applied over [t_k, t_k+1) (zero-order hold)",
    "u_mean": "mean applied force over [t_k - dt/2, t_k + dt/2): (u[k-1] + u[k]) / 2",
    "stuck": "stage at rest at t_k",
    "sliding": "slid in one direction, never stuck, throughout [t_k-1, t_k+1)",
}


class _Constants(NamedTuple):
    """Stage and controller parameters as a pytree of floats (traced, so no recompilation)."""

    M: float
    Fv_pos: float
    Fv_neg: float
    Fc: float
    Fc_slope: float
    x_centre: float
    offset: float
    static_ratio: float
    Kp: float
    Kd: float
    alpha: float  # derivative low-pass pole, exp(-2 pi f_d dt)
    step: float  # encoder step
    dt: float  # sampling interval (the controller's period)
    dt_sub: float  # substep


def _substep(c: _Constants, F_app, dt, state):
    x, v, stuck, clean = state
    fc = jnp.maximum(c.Fc + c.Fc_slope * (x - c.x_centre), 0.0)
    F_s = fc * c.static_ratio
    f_start = fc * jnp.sign(F_app)  # Coulomb friction at v = 0+ in the direction of F_app
    breaks = jnp.abs(F_app) > F_s
    friction = jnp.where(breaks, f_start, F_app)
    a = jnp.where(stuck & ~breaks, 0.0, (F_app - friction) / c.M)
    # sliding: the viscous force at the substep's mean velocity (trapezoid, solved for v_new):
    # at the old velocity it would lag by half a substep, which reads as a mass M - Fv dt / 2
    k = jnp.where(v > 0, c.Fv_pos, c.Fv_neg) * dt / (2 * c.M)
    v_slide = (v * (1 - k) + (F_app - fc * jnp.sign(v)) * dt / c.M) / (1 + k)
    a = jnp.where(stuck, a, (v_slide - v) / dt)
    v_new = v + a * dt
    # A sliding stage that reaches v = 0 within the substep spends the rest of it as a stuck one:
    # it breaks away again only if the applied force exceeds the breakaway level.
    reversed_ = ~stuck & (v_new * v <= 0)
    rest = jnp.where(reversed_, v_new / jnp.where(reversed_ & (a != 0), a * dt, 1.0), 0.0)
    rebreaks = reversed_ & breaks
    v_rebound = (F_app - f_start) / c.M * rest * dt
    v_new = jnp.where(reversed_, jnp.where(rebreaks, v_rebound, 0.0), v_new)
    # the trapezoid, not x + v_new dt: that would run the position half a substep ahead of the
    # forces, which identification reads as viscous friction of M dt_sub omega² / 2
    x_new = x + 0.5 * (v + v_new) * dt
    stuck_new = jnp.where(stuck, ~breaks, reversed_ & ~rebreaks)
    return x_new, v_new, stuck_new, clean & ~stuck & ~reversed_


def _sample(params: _Constants, state, inputs, substeps: int):
    c = params
    x, v, stuck, e_prev, d_prev = state
    r_k, noise_k, ff_k = inputs
    counts = jnp.round((x + noise_k) / c.step)
    e = r_k - counts * c.step
    d = c.alpha * d_prev + (1.0 - c.alpha) * (e - e_prev) / c.dt
    u = ff_k + c.Kp * e + c.Kd * d
    F_app = u - c.offset

    def body(_, st):
        return _substep(c, F_app, c.dt_sub, st)

    x1, v1, stuck1, clean = jax.lax.fori_loop(0, substeps, body, (x, v, stuck, True))
    out = {"x": x, "v": v, "stuck": stuck, "counts": counts, "u": u, "v_end": v1, "clean": clean}
    return (x1, v1, stuck1, e, d), out


def _constants(
    stage: LinearMotorParams,
    controller: PDController | None,
    rate: float,
    step: float,
    substeps: int,
) -> _Constants:
    if controller is None:  # open loop: the feed-forward is the whole command
        Kp = Kd = alpha = 0.0
    else:
        Kp, Kd = controller.Kp, controller.Kd
        alpha = float(np.exp(-2 * np.pi * controller.derivative_cutoff_hz / rate))
    dt = 1.0 / rate
    return _Constants(
        stage.M, stage.Fv, stage.Fv_neg, stage.Fc, stage.Fc_slope, stage.x_centre, stage.offset,
        stage.static_ratio, Kp, Kd, alpha, step, dt, dt / substeps,
    )  # fmt: skip


@dataclass(frozen=True)
class LinearMotor(SimulatedRig):
    """The stage under its PD loop for :func:`~hmid.simulate.rig.integrate`, from rest at x = 0.

    Inputs: the reference ``r`` (m); optionally ``position_noise`` (m, added to the true
    position before the encoder rounds it) and ``feedforward`` (N, added to the PD command;
    without a controller it is the whole command: open loop). Before t_0 the drive is off
    (u[-1] = 0).
    """

    params: LinearMotorParams
    controller: PDController | None
    encoder_step: float

    name: ClassVar[str] = "linear-motor"
    inputs: ClassVar[tuple[str, ...]] = ("r", "position_noise", "feedforward")
    signals: ClassVar[Mapping[str, str]] = SIGNALS
    first_sample: ClassVar[int] = 0  # the state at the start of each interval
    finite: ClassVar[tuple[str, ...]] = ("x", "u", "v_end")
    diverged: ClassVar[str] = "the controller gains may be unstable at this rate"
    sample = staticmethod(_sample)

    def prepare(self, inputs, rate, substeps):
        r = np.asarray(inputs["r"], dtype=float)
        n = len(r)
        noise, ff = (inputs.get(k) for k in ("position_noise", "feedforward"))
        noise = np.zeros(n) if noise is None else np.asarray(noise, dtype=float)
        ff = np.zeros(n) if ff is None else np.asarray(ff, dtype=float)
        zero = jnp.float64(0.0)
        init = (zero, zero, jnp.bool_(True), zero, zero)
        c = _constants(self.params, self.controller, rate, self.encoder_step, substeps)
        return c, init, (jnp.asarray(r), jnp.asarray(noise), jnp.asarray(ff))

    def trajectory(self, t, rate, inputs, out):
        x, v, u, clean = out["x"], out["v"], out["u"], out["clean"]
        dt = 1.0 / rate
        v_prev = np.r_[0.0, v[:-1]]  # at rest before t_0
        a = (out["v_end"] - v_prev) / (2 * dt)
        signals = {
            "r": np.asarray(inputs["r"], dtype=float),
            "x": x,
            "v": v,
            "a": a,
            "x_meas": out["counts"] * self.encoder_step,
            "u": u,
            "u_mean": 0.5 * (np.r_[0.0, u[:-1]] + u),
            "stuck": out["stuck"],
            "sliding": np.r_[False, clean[:-1] & clean[1:]],
        }
        return Trajectory(t, signals)


def balance_residual(stage: LinearMotorParams, traj: Trajectory) -> np.ndarray:
    """u_mean - (M a + Fv(v) v + Fc(x) sign(v) + offset) at each sample, on the true motion.

    Small at sliding samples (the integrator's substep lag); meaningless where the stage sticks.
    """
    return traj.u_mean - (stage.M * traj.a + stage.friction(traj.x, traj.v) + stage.offset)
