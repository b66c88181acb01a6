"""The controllers: the thesis's PD set-point tracker, and model-based feed-forward plus the same
PD (thesis Fig. 1.3).

Both are one :class:`Tracker`: effort = feed-forward + PD(error), realised on the valves by an
:mod:`~hmid.control.actuation`. They differ only in the feed-forward the reference carries:

* **PD alone**: the pressure that holds the reference's starting point (a set-point tracker
  needs its operating point's pressure; without it the PD's error would carry the muscle's
  whole load);
* **model-based**: the inverse dynamics of an identified model along the reference
  (:mod:`hmid.control.inverse`), then the valve's lag inverted.

So "at the same gains" holds by construction. The tracker reads the tracked output as its sensor
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

    def step(self, state: Any, error: Any) -> tuple[Any, Any]:
        last, rate, started = state
        last = jnp.where(started, last, error)  # no derivative kick at the first sample
        a = jnp.exp(-self.dt / self.tf)
        rate = a * rate + (1 - a) * (error - last) / self.dt
        return (error, rate, jnp.ones((), dtype=bool)), self.kp * error + self.kd * rate


class Tracker(eqx.Module):
    """Feed-forward plus PD on the tracked output; ``reference`` at each sample is a dict with
    ``r`` (the reference), ``ff`` (the feed-forward effort) and ``noise`` (sensor noise)."""

    pd: PD
    tracked: str = eqx.field(static=True)
    resolution: Any = 0.0  # the sensor's step (0: not quantised)
    actuation: Actuation = Proportional()
    feedback: Any = 1.0  # 0: feed-forward alone (the perfect-model check)

    def init(self) -> Any:
        return (self.pd.init(), self.actuation.init())

    def step(self, state: Any, measured: Any, reference: Any) -> tuple[Any, dict]:
        pd_state, act_state = state
        y = measured[self.tracked] + reference["noise"]
        step = jnp.where(self.resolution > 0, self.resolution, 1.0)
        y = jnp.where(self.resolution > 0, jnp.round(y / step) * step, y)
        pd_state, u = self.pd.step(pd_state, reference["r"] - y)
        effort = reference["ff"] + self.feedback * u
        act_state, commands = self.actuation.realise(act_state, effort, measured)
        return (pd_state, act_state), commands
