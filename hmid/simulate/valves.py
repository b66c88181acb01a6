"""Valves between the supply and a muscle: how a command becomes the pressure in the muscle.

Two kinds, each a frozen config with a JAX step (one substep ``dt``, float64):

* :class:`ProportionalValve` (thesis §8's recommendation): the pressure follows a commanded
  pressure through the line's first-order lag, limited by the flow (a slew rate). The Ch. 4 rig's
  own valve (:class:`~hmid.simulate.params.ValveParams`) is this one.
* :class:`OnOffValves` (the thesis's commercial solenoid valves): an inlet to the supply and an
  outlet to the atmosphere, each open or shut. The command is +1 (fill: inlet open), 0 (hold:
  both shut) or -1 (vent: outlet open); an intermediate value opens the valve partly, as
  the mean of a PWM duty cycle does. Each valve's opening moves toward its command at its own
  opening and closing speed (Ch. 6: the travel times differ by direction because the valves
  open and close at different speeds), and the line fills or drains through what is open:
  dP/dt = (s_in (P_supply - P) - s_out P) / tau_line.

The state of a valve is (opening of the inlet, opening of the outlet); a proportional valve has
none (its state is the pressure itself).
"""

from __future__ import annotations

from typing import Any

import jax.numpy as jnp

from hmid.simulate.params import Positive, _Frozen


class ProportionalValve(_Frozen):
    """The pressure follows the command through a slew-limited first-order lag."""

    tau: Positive = 0.03  # s, line/compliance time constant
    slew: Positive = 1.5e6  # Pa/s, flow-limited maximum rate of change

    def initial(self) -> Any:
        return ()

    def step(self, state: Any, P: Any, command: Any, dt: float) -> tuple[Any, Any]:
        """(state, pressure) after ``dt`` for the commanded pressure ``command`` (Pa)."""
        target = command + (P - command) * jnp.exp(-dt / self.tau)  # exact for any tau
        return state, P + jnp.clip(target - P, -self.slew * dt, self.slew * dt)


class OnOffValves(_Frozen):
    """An inlet and an outlet solenoid valve per muscle; command +1 fill, 0 hold, -1 vent."""

    supply: Positive = 6.0e5  # Pa, gauge pressure behind the inlet
    opening_time: Positive = 0.02  # s, shut -> fully open
    closing_time: Positive = 0.06  # s, fully open -> shut
    line_tau: Positive = 0.05  # s, fill/drain time constant of the line through an open valve

    def initial(self) -> Any:
        return (jnp.float64(0.0), jnp.float64(0.0))

    def step(self, state: Any, P: Any, command: Any, dt: float) -> tuple[Any, Any]:
        """(openings, pressure) after ``dt`` for the command in [-1, 1]."""
        return fill_vent(self, state, P, command, dt)


def fill_vent(valves: Any, state: Any, P: Any, command: Any, dt: Any) -> tuple[Any, Any]:
    """One step of inlet and outlet solenoid valves: ``valves`` is anything with the fields of
    :class:`OnOffValves` (the config, or a rig's traced copy of its numbers)."""
    s_in, s_out = state
    want_in, want_out = jnp.clip(command, 0.0, 1.0), jnp.clip(-command, 0.0, 1.0)

    def move(s, want):
        rate = jnp.where(want > s, 1.0 / valves.opening_time, 1.0 / valves.closing_time)
        return s + jnp.clip(want - s, -rate * dt, rate * dt)

    s_in, s_out = move(s_in, want_in), move(s_out, want_out)
    # exact step of the linear line equation for the openings held over dt
    g = (s_in + s_out) / valves.line_tau
    target = jnp.where(g > 0, s_in * valves.supply / jnp.where(g > 0, g * valves.line_tau, 1), P)
    P = target + (P - target) * jnp.exp(-g * dt)
    return (s_in, s_out), P


Valve = ProportionalValve | OnOffValves
