"""Extra physical effects a simulation can switch on without declaring them to the pipeline.

They are the raw material for testing whether identification notices physics its model lacks.
Each effect is a small :class:`Effect` (an equinox module, so its parameters are traced rather
than compiled in) that overrides one or more hooks:

* ``breakaway(P, x)``  extra static-friction level (N, >= 0) that must be overcome to start sliding;
* ``sliding(v, P, x)`` extra friction force while sliding (N, signed, opposing v);
* ``stiffness(t)``     factor on the latex's elastic forces;
* ``sense(channel, t, y)`` changes what a sensor reports (NumPy, on the true signal before noise
  and quantisation).

``signals`` lists the logged channels an effect may change; everything else must stay identical.
New effects register themselves by subclassing; :func:`make_effect` builds one from a config
mapping such as ``{"kind": "stribeck", "delta": 0.15, "v_s": 0.004}``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from hmid.errors import ConfigError

EFFECTS: dict[str, type[Effect]] = {}


class Effect(eqx.Module):
    """Base class: every hook defaults to "no change"."""

    kind: ClassVar[str] = ""
    signals: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.kind:
            EFFECTS[cls.kind] = cls

    def breakaway(self, P, x):
        return 0.0

    def sliding(self, v, P, x):
        return 0.0

    def stiffness(self, t):
        return 1.0

    def sense(self, channel: str, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        return y

    def params(self) -> dict[str, float]:
        """Physical parameters, for the ground-truth record."""
        return {f.name: float(getattr(self, f.name)) for f in dataclasses.fields(self)}


def _check(condition: bool, kind: str, message: str) -> None:
    if not condition:
        raise ConfigError(f"effect {kind!r}: {message}")


class ViscousFriction(Effect):
    """Viscous friction b v (lubricated rail, fluid drag): friction force growing with speed."""

    kind: ClassVar[str] = "viscous"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    b: float = 4.0  # N s/m

    def __check_init__(self):
        _check(self.b >= 0, self.kind, f"b={self.b} must be >= 0 N s/m")

    def sliding(self, v, P, x):
        return self.b * v


class StribeckFriction(Effect):
    """Stribeck friction: extra friction ``delta`` at rest that fades with speed, exp(-|v/v_s|^2).

    A real rig shows a breakaway peak larger than the sliding friction and stick-slip at low speed.
    """

    kind: ClassVar[str] = "stribeck"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    delta: float = 0.2  # N, static excess over Coulomb
    v_s: float = 0.005  # m/s, Stribeck velocity

    def __check_init__(self):
        _check(self.delta >= 0, self.kind, f"delta={self.delta} must be >= 0 N")
        _check(self.v_s > 0, self.kind, f"v_s={self.v_s} must be > 0 m/s")

    def breakaway(self, P, x):
        return self.delta

    def sliding(self, v, P, x):
        return jnp.sign(v) * self.delta * jnp.exp(-((v / self.v_s) ** 2))


class PressureFriction(Effect):
    """Friction growing with pressure, mu P (a pressurised sheath or seal pressed on its guide)."""

    kind: ClassVar[str] = "pressure_friction"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    mu: float = 1.5e-6  # N/Pa

    def __check_init__(self):
        _check(self.mu >= 0, self.kind, f"mu={self.mu} must be >= 0 N/Pa")

    def breakaway(self, P, x):
        return self.mu * jnp.maximum(P, 0.0)

    def sliding(self, v, P, x):
        return jnp.sign(v) * self.mu * jnp.maximum(P, 0.0)


class PressureSensorLag(Effect):
    """The pressure sensor reports late: a transport delay plus a first-order lag (tubing, filter).

    A real rig shows hysteresis-like loops of force against measured pressure that shrink at low
    excitation frequency.
    """

    kind: ClassVar[str] = "pressure_lag"
    signals: ClassVar[tuple[str, ...]] = ("P",)
    delay: float = 0.02  # s
    tau: float = 0.0  # s, first-order lag after the delay

    def __check_init__(self):
        _check(self.delay >= 0, self.kind, f"delay={self.delay} must be >= 0 s")
        _check(self.tau >= 0, self.kind, f"tau={self.tau} must be >= 0 s")

    def sense(self, channel, t, y):
        if channel != "P":
            return y
        out = np.interp(t - self.delay, t, y)  # before t0 the sensor holds the first value
        if self.tau > 0:
            from scipy.signal import lfilter

            alpha = 1.0 - np.exp(-np.median(np.diff(t)) / self.tau)
            out, _ = lfilter([alpha], [1.0, alpha - 1.0], out, zi=[(1.0 - alpha) * out[0]])
        return out


class StiffnessDrift(Effect):
    """The latex softens over the test (warm-up): stiffness x (1 - fraction (1 - exp(-t/tau)))."""

    kind: ClassVar[str] = "stiffness_drift"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    fraction: float = 0.08
    tau: float = 20.0  # s

    def __check_init__(self):
        _check(0 <= self.fraction < 1, self.kind, f"fraction={self.fraction} must be in [0, 1)")
        _check(self.tau > 0, self.kind, f"tau={self.tau} must be > 0 s")

    def stiffness(self, t):
        return 1.0 - self.fraction * (1.0 - jnp.exp(-t / self.tau))


class RailRipple(Effect):
    """Friction varying along the rail, amplitude (1 + sin(2 pi x / wavelength)): waviness, debris.

    Deliberately outside the usual candidate effects: a test of the "unexplained structure" path.
    """

    kind: ClassVar[str] = "rail_ripple"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    amplitude: float = 0.1  # N
    wavelength: float = 0.004  # m

    def __check_init__(self):
        _check(self.amplitude >= 0, self.kind, f"amplitude={self.amplitude} must be >= 0 N")
        _check(self.wavelength > 0, self.kind, f"wavelength={self.wavelength} must be > 0 m")

    def _level(self, x):
        return self.amplitude * (1.0 + jnp.sin(2 * jnp.pi * x / self.wavelength))

    def breakaway(self, P, x):
        return self._level(x)

    def sliding(self, v, P, x):
        return jnp.sign(v) * self._level(x)


class LoadCellDrift(Effect):
    """The load cell's zero drifts (temperature): the force channel gains offset + rate t."""

    kind: ClassVar[str] = "load_cell_drift"
    signals: ClassVar[tuple[str, ...]] = ("F",)
    offset: float = 0.0  # N
    rate: float = 0.002  # N/s

    def sense(self, channel, t, y):
        return y + self.offset + self.rate * (t - t[0]) if channel == "F" else y


def make_effect(spec: Mapping[str, object] | Effect) -> Effect:
    """An effect from ``{"kind": ..., **parameters}``; unknown kinds or keys are ConfigErrors."""
    if isinstance(spec, Effect):
        return spec
    if not isinstance(spec, Mapping) or "kind" not in spec:
        raise ConfigError(f"effect {spec!r}: needs a 'kind', one of {sorted(EFFECTS)}")
    params = dict(spec)
    kind = params.pop("kind")
    if kind not in EFFECTS:
        raise ConfigError(f"effect kind {kind!r} is unknown; known kinds: {sorted(EFFECTS)}")
    cls = EFFECTS[kind]
    allowed = [f.name for f in dataclasses.fields(cls)]
    for key, value in params.items():
        if key not in allowed:
            raise ConfigError(f"effect {kind!r}: unknown key {key!r}; allowed keys: {allowed}")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"effect {kind!r}: key {key!r} must be a number, got {value!r}")
    return cls(**{k: float(v) for k, v in params.items()})
