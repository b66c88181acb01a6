"""Extra physical effects a simulation can switch on without declaring them to the pipeline.

They are the raw material for testing whether identification notices physics its model lacks.
Each effect is a small :class:`Effect` (an equinox module, so its parameters are traced rather
than compiled in) that overrides one or more hooks:

* ``breakaway(P, x)``  extra static-friction level (N, >= 0 except where an effect lowers the
  rig's level, as ``position_friction`` may) that must be overcome to start sliding;
* ``sliding(v, P, x)`` extra friction force while sliding (N, signed, opposing v);
* ``stiffness(t)``     factor on the latex's elastic forces;
* ``muscle(t, x, v, P)`` extra muscle force (N, along +x) beside the latex's springs, e.g. a
  dashpot; it acts only with the muscle connected (not in free-fall tests);
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

    def muscle(self, t, x, v, P):
        return 0.0

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


class LatexSoftening(Effect):
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


class PositionFriction(Effect):
    """Coulomb friction changing linearly along the rail, slope (x - x_ref): a worn or tilted rail.

    The extra level is added to the rig's Coulomb friction as given, for breakaway and sliding
    (sign(v) slope (x - x_ref)); it is negative on one side of ``x_ref`` for a positive slope.
    With ``span`` > 0 the change stops at |x - x_ref| = span (the worn stretch ends): free falls
    far along the rail then see a constant extra level. The effect does not know the rig's base
    level, so it cannot check the sum: keep the rig's total Coulomb level >= 0 over the travel
    (20 N/m over the demo's ~10 mm changes friction by 0.2 N).
    """

    kind: ClassVar[str] = "position_friction"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    slope: float = 20.0  # N/m, may be negative
    x_ref: float = 0.0  # m, where the extra level is zero
    span: float = 0.0  # m, beyond |x - x_ref| = span the level stops changing (0: no end)

    def __check_init__(self):
        _check(np.isfinite(self.slope), self.kind, f"slope={self.slope} must be finite (N/m)")
        _check(np.isfinite(self.x_ref), self.kind, f"x_ref={self.x_ref} must be finite (m)")
        _check(self.span >= 0, self.kind, f"span={self.span} must be >= 0 m (0: no end)")

    def _level(self, x):
        offset = x - self.x_ref
        ended = jnp.clip(offset, -self.span, self.span)
        return self.slope * jnp.where(self.span > 0, ended, offset)

    def breakaway(self, P, x):
        return self._level(x)

    def sliding(self, v, P, x):
        return jnp.sign(v) * self._level(x)


class DirectionViscous(Effect):
    """Viscous friction with a coefficient per direction: b_pos v for v > 0, b_neg v for v < 0.

    A seal or wiper that drags more one way than the other; a real rig shows friction loops whose
    width differs between extension and retraction.
    """

    kind: ClassVar[str] = "direction_viscous"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    b_pos: float = 3.0  # N s/m, extending (v > 0)
    b_neg: float = 0.0  # N s/m, retracting (v < 0)

    def __check_init__(self):
        _check(self.b_pos >= 0, self.kind, f"b_pos={self.b_pos} must be >= 0 N s/m")
        _check(self.b_neg >= 0, self.kind, f"b_neg={self.b_neg} must be >= 0 N s/m")

    def sliding(self, v, P, x):
        return jnp.where(v > 0, self.b_pos, self.b_neg) * v


class PositionSensorDelay(Effect):
    """The position sensor reports late and in steps: a sample-and-hold, then a transport delay.

    The logged x at time t is the true x at the last hold instant k hold <= t - delay (absolute
    simulation time, interpolated between samples; hold = 0: no hold). Before the first sample the
    sensor holds the first value. A slow encoder bus or camera: force leads position.
    """

    kind: ClassVar[str] = "position_sensor_delay"
    signals: ClassVar[tuple[str, ...]] = ("x",)
    delay: float = 0.016  # s
    hold: float = 0.0165  # s, sample-and-hold period

    def __check_init__(self):
        _check(self.delay >= 0, self.kind, f"delay={self.delay} must be >= 0 s")
        _check(self.hold >= 0, self.kind, f"hold={self.hold} must be >= 0 s")

    def sense(self, channel, t, y):
        if channel != "x":
            return y
        when = t - self.delay
        if self.hold > 0:
            # + 1e-9: an instant that lands on a sample time is not rounded to the one before
            when = np.floor(when / self.hold + 1e-9) * self.hold
        return np.interp(when, t, y)  # before t0 the sensor holds the first value


class MuscleDamping(Effect):
    """A dashpot inside the muscle, parallel to its springs: the muscle force gains -c v.

    Unlike viscous rail friction it acts only with the muscle connected: free falls do not show it.
    """

    kind: ClassVar[str] = "muscle_damping"
    signals: ClassVar[tuple[str, ...]] = ("x", "F")
    c: float = 3.0  # N s/m

    def __check_init__(self):
        _check(self.c >= 0, self.kind, f"c={self.c} must be >= 0 N s/m")

    def muscle(self, t, x, v, P):
        return -self.c * v


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
    numbers: dict[str, float] = {}
    for key, value in params.items():
        if key not in allowed:
            raise ConfigError(f"effect {kind!r}: unknown key {key!r}; allowed keys: {allowed}")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"effect {kind!r}: key {key!r} must be a number, got {value!r}")
        numbers[key] = float(value)
    return cls(**numbers)
