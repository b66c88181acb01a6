"""The controllers: the thesis's PD set-point tracker, model-based feed-forward plus the same
PD (thesis Fig. 1.3), and that plus integral action (:class:`PID`).

All are one :class:`Tracker`: effort = feed-forward + feedback(error), realised on the valves by
an :mod:`~hmid.control.actuation`. PD alone and FF+PD differ only in the feed-forward the
reference carries:

* **PD alone**: the pressure that holds the reference's starting point (a set-point tracker
  needs its operating point's pressure; without it the PD's error would carry the muscle's
  whole load);
* **model-based**: the inverse dynamics of an identified model along the reference
  (:mod:`hmid.control.inverse`), then the valve's lag inverted.

So "at the same gains" holds by construction. ``FF+PID`` adds to FF+PD's feedback an integral
of the error (its own gains, :mod:`hmid.control.integral`): the feed-forward is the model's, so
what the model misses (an undeclared effect, a fibre unlike its type's model) is a disturbance
the PD alone leaves as a steady error, and the integral takes it back. Its anti-windup is
conditional integration: the integral stops while the effort is past what the valves can give
(``low``, ``high``) and the error pushes it further, and never exceeds that span. It integrates
only errors the sensor can tell from none (``deadband``, half the sensor's step): a quantised
reading of a target between two steps is never zero, and an integral of that remainder would
push the output to the edge of the sensor's step (a limit cycle there, and hunting against
static friction) rather than hold it where the feed-forward put it.

The tracker reads the tracked output as its sensor
gives it (quantised to the sensor's resolution, with the sensor noise the reference carries),
and the D part acts on the error through a first-order filter (time constant ``tf``): a raw
difference of a 0.02 mm-quantised position at 1 kHz is 0.02 m/s of noise per count.

The tracker runs inside :func:`hmid.simulate.rig.closed_loop`'s scan: an equinox module whose
gains are arrays (traced: new gains do not recompile) and whose names are static.
"""

from __future__ import annotations

from typing import Any

import equinox as eqx
import jax.numpy as jnp

from hmid.control.actuation import Actuation, Proportional


class PD(eqx.Module):
    """u = kp e + kd de/dt, the derivative through a first-order filter (time constant tf),
    at the sampling interval dt."""

    kp: Any
    kd: Any
    tf: Any
    dt: Any

    def init(self) -> Any:
        return (jnp.zeros(()), jnp.zeros(()), jnp.zeros((), dtype=bool))

    def step(self, state: Any, error: Any, ff: Any = 0.0) -> tuple[Any, Any]:
        """(state, u) after the error ``error``; ``ff`` (the feed-forward) is unused: a PD does
        not wind up."""
        last, rate, started = state
        last = jnp.where(started, last, error)  # no derivative kick at the first sample
        a = jnp.exp(-self.dt / self.tf)
        rate = a * rate + (1 - a) * (error - last) / self.dt
        return (error, rate, jnp.ones((), dtype=bool)), self.kp * error + self.kd * rate


class PID(eqx.Module):
    """u = PD(e) + I, I the integral of ki e (forward rectangles: I_k = I_(k-1) + ki dt e_k)
    where |e| > ``deadband``, frozen while ff + u is past [low, high] and ki e pushes it further,
    and within the span +-(high - low) (anti-windup; see the module's docstring)."""

    pd: PD
    ki: Any
    low: Any  # the effort the valves can give (Pa)
    high: Any
    deadband: Any = 0.0  # errors within it are none (half the sensor's step)

    def init(self) -> Any:
        return (self.pd.init(), jnp.zeros(()))

    def step(self, state: Any, error: Any, ff: Any = 0.0) -> tuple[Any, Any]:
        pd_state, integral = state
        pd_state, u = self.pd.step(pd_state, error)
        grow = jnp.where(jnp.abs(error) > self.deadband, self.ki * self.pd.dt * error, 0.0)
        total = ff + u + integral + grow
        wind = ((total > self.high) & (grow > 0)) | ((total < self.low) & (grow < 0))
        span = self.high - self.low
        integral = jnp.clip(jnp.where(wind, integral, integral + grow), -span, span)
        return (pd_state, integral), u + integral


class Tracker(eqx.Module):
    """Feed-forward plus feedback (:class:`PD`, :class:`PID` or the PD with a disturbance
    observer, :class:`hmid.control.observer.DOB`) on the tracked output;
    ``reference`` at each sample is a dict with ``r`` (the reference), ``ff`` (the feed-forward
    effort) and ``noise`` (sensor noise)."""

    law: Any  # PD, PID or hmid.control.observer.DOB
    tracked: str = eqx.field(static=True)
    resolution: Any = 0.0  # the sensor's step (0: not quantised)
    actuation: Actuation = Proportional()
    feedback: Any = 1.0  # 0: feed-forward alone (the perfect-model check)

    def init(self) -> Any:
        return (self.law.init(), self.actuation.init())

    def step(self, state: Any, measured: Any, reference: Any) -> tuple[Any, dict]:
        law_state, act_state = state
        y = measured[self.tracked] + reference["noise"]
        step = jnp.where(self.resolution > 0, self.resolution, 1.0)
        y = jnp.where(self.resolution > 0, jnp.round(y / step) * step, y)
        law_state, u = self.law.step(law_state, reference["r"] - y, reference["ff"])
        effort = reference["ff"] + self.feedback * u
        act_state, commands = self.actuation.realise(act_state, effort, measured)
        return (law_state, act_state), commands
