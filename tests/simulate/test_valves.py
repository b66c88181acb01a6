"""The valves: a proportional valve follows its command; on/off valves fill, hold and vent, and
open and close at their own speeds."""

import jax
import numpy as np
import pytest

from hmid.simulate.valves import OnOffValves, ProportionalValve

DT = 1e-4


def run(valve, commands, P0=0.0):
    with jax.enable_x64(True):
        state, P, out = valve.initial(), P0, []
        for u in commands:
            state, P = valve.step(state, P, u, DT)
            out.append(float(P))
    return np.array(out)


def test_a_proportional_valve_settles_on_its_command():
    P = run(ProportionalValve(tau=0.01, slew=1e7), [2e5] * 2000)
    assert P[-1] == pytest.approx(2e5, rel=1e-6)
    assert np.all(np.diff(P) >= 0)


def test_a_proportional_valve_is_flow_limited():
    P = run(ProportionalValve(tau=1e-3, slew=1e6), [5e5] * 100)
    assert np.max(np.diff(P)) == pytest.approx(1e6 * DT)


def test_on_off_valves_fill_hold_and_vent():
    valves = OnOffValves(supply=5e5, opening_time=0.01, closing_time=0.01, line_tau=0.02)
    fill = run(valves, [1.0] * 3000)
    assert fill[-1] == pytest.approx(5e5, rel=1e-3)
    held = run(valves, [0.0] * 2000, P0=2e5)
    assert held[-1] == pytest.approx(2e5)
    vent = run(valves, [-1.0] * 3000, P0=2e5)
    assert vent[-1] == pytest.approx(0.0, abs=100.0)


def test_a_slow_closing_valve_overshoots_a_fill_more_than_a_fast_one():
    """Ch. 6: the travel times differ by direction because the valves open and close at
    different speeds; a valve that shuts slowly lets more fluid through after the command."""
    pulse = [1.0] * 200 + [0.0] * 3000
    fast = run(OnOffValves(opening_time=0.02, closing_time=0.02), pulse)
    slow = run(OnOffValves(opening_time=0.02, closing_time=0.1), pulse)
    assert slow[-1] > 1.5 * fast[-1]
    assert fast[-1] == pytest.approx(fast[-500])  # held once both are shut


def test_a_partial_command_fills_slower_as_a_pwm_duty_cycle_would():
    full, half = run(OnOffValves(), [1.0] * 500), run(OnOffValves(), [0.5] * 500)
    assert 0 < half[-1] < 0.8 * full[-1]
