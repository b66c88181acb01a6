"""How a controller's pressure command reaches the valves: proportional, switching or PWM.

A controller computes an *effort*, the pressure it wants (Pa). A proportional valve takes it as
its command (thesis §8's recommendation). On/off valves (:class:`~hmid.simulate.valves.
OnOffValves`: an inlet and an outlet solenoid, +1 fill, 0 hold, -1 vent) cannot: the command is
realised by switching them on the measured pressure's error, the way the thesis's
microcontroller did (Ch. 6), either

* :class:`Switching`: fill while the pressure is more than ``band`` below the command, vent
  while it is more than ``band`` above, hold in between (a three-level relay: every crossing of
  the band is a switching, and the band sets the pressure's ripple); or
* :class:`PWM`: at the start of every ``period`` the duty is the error over ``span`` (clipped
  to [-1, 1]); the inlet (or outlet) is open for that fraction of the period.

Each realisation is a small equinox module run inside the closed loop's scan; it returns the
rig's input commands by name, so a rig with several muscles (the ankle) brings its own (one
effort to each engaged fibre's valves). :func:`switchings` counts the valve operations of a
run's commands, what wears a solenoid valve out.
"""

from __future__ import annotations

from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np


class Proportional(eqx.Module):
    """The effort is the proportional valve's command, within [lowest, highest] (Pa)."""

    lowest: float = 0.0
    highest: float = 6.0e5
    command: str = eqx.field(static=True, default="P_cmd")

    def init(self) -> Any:
        return ()

    def realise(self, state: Any, effort: Any, measured: Any) -> tuple[Any, dict]:
        return state, {self.command: jnp.clip(effort, self.lowest, self.highest)}


class Switching(eqx.Module):
    """Fill below ``command - band``, vent above ``command + band``, hold between (on the
    rig's pressure output)."""

    band: Any = 5.0e3  # Pa
    pressure: str = eqx.field(static=True, default="P")
    command: str = eqx.field(static=True, default="P_cmd")
    valve: str = eqx.field(static=True, default="valve")

    def init(self) -> Any:
        return ()

    def realise(self, state: Any, effort: Any, measured: Any) -> tuple[Any, dict]:
        error = effort - measured[self.pressure]
        u = jnp.where(error > self.band, 1.0, jnp.where(error < -self.band, -1.0, 0.0))
        return state, {self.command: effort, self.valve: u}


class PWM(eqx.Module):
    """Pulse-width modulation: every ``period`` samples the duty is error / ``span``, and the
    inlet (duty > 0) or the outlet (duty < 0) opens for that share of the period."""

    period: int = eqx.field(static=True, default=20)  # samples
    span: Any = 5.0e4  # Pa of error for a full duty
    pressure: str = eqx.field(static=True, default="P")
    command: str = eqx.field(static=True, default="P_cmd")
    valve: str = eqx.field(static=True, default="valve")

    def init(self) -> Any:
        return (jnp.zeros((), dtype=jnp.int32), jnp.zeros(()))

    def realise(self, state: Any, effort: Any, measured: Any) -> tuple[Any, dict]:
        count, duty = state
        fresh = jnp.clip((effort - measured[self.pressure]) / self.span, -1.0, 1.0)
        duty = jnp.where(count == 0, fresh, duty)
        on = (count + 0.5) < jnp.abs(duty) * self.period
        u = jnp.where(on, jnp.sign(duty), 0.0)
        return ((count + 1) % self.period, duty), {self.command: effort, self.valve: u}


Actuation = Proportional | Switching | PWM


def switchings(valve: np.ndarray) -> int:
    """Valve operations in a run's on/off commands: every opening and every closing of the
    inlet (command > 0) and of the outlet (command < 0), from both shut; summed over the
    columns of several valves' commands (samples x valves)."""
    valve = np.asarray(valve, dtype=float)
    if valve.ndim == 2:
        return sum(switchings(column) for column in valve.T)
    count = 0
    for open_ in (valve > 0, valve < 0):
        state = np.concatenate([[False], open_])
        count += int(np.count_nonzero(state[1:] != state[:-1]))
    return count
