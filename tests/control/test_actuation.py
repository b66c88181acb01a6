"""On/off valves on the Ch. 4 rig: fill, hold and vent move the pressure as the valve model
says; a switching realisation holds a commanded pressure near its band; switchings counted."""

import numpy as np
import pytest

from hmid.control.actuation import Switching, switchings
from hmid.simulate.params import RigParams
from hmid.simulate.rig import closed_loop, integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle
from hmid.simulate.valves import OnOffValves

N = 600


def test_fill_hold_and_vent():
    valve = np.concatenate([np.ones(100), np.zeros(200), -np.ones(300)])
    rig = HydroMuscle(RigParams(), valves=OnOffValves(), x0=0.006)  # the block clamped
    held = np.ones(N, dtype=bool)
    traj = integrate(rig, {"P_cmd": np.full(N, 1e5), "valve": valve, "held": held}, 1000.0)
    assert traj.P[99] > 1.2e5  # filled
    assert traj.P[299] == pytest.approx(traj.P[160], rel=1e-3)  # held once the inlet shut
    assert traj.P[-1] < traj.P[299] - 5e4  # vented


def test_the_rigs_own_valve_ignores_the_on_off_command():
    P = np.full(N, 1.2e5)
    rig = HydroMuscle(RigParams())
    plain = integrate(rig, {"P_cmd": P}, 1000.0)
    commanded = integrate(rig, {"P_cmd": P, "valve": np.ones(N)}, 1000.0)
    assert np.array_equal(plain.P, commanded.P) and np.array_equal(plain.x, commanded.x)


class _Hold:
    """A controller that asks the switching realisation for one pressure."""

    def __init__(self, realisation):
        self.realisation = realisation

    def init(self):
        return self.realisation.init()

    def step(self, state, measured, reference):
        return self.realisation.realise(state, reference, measured)


def test_switching_holds_a_pressure_near_its_band():
    out0 = {"P": 1e5, "x": 0.0, "v": 0.0, "a": 0.0, "F_m": 0.0, "friction": 0.0, "q": 0.0,
            "stuck": True, "contact": False, "tension_min": 0.0}  # fmt: skip
    rig = HydroMuscle(RigParams(), valves=OnOffValves(), x0=0.006)  # the block clamped
    target = np.full(2000, 1.5e5)
    inputs = {"P_cmd": np.full(2000, 1e5), "held": np.ones(2000, dtype=bool)}
    traj, commands = closed_loop(rig, _Hold(Switching(band=3e3)), target, 1000.0,
                                 initial_inputs=inputs, initial_outputs=out0)  # fmt: skip
    settled = traj.P[1000:]
    assert abs(np.mean(settled) - 1.5e5) < 1e4
    assert switchings(commands["valve"]) >= 2


def test_switchings_count_every_opening_and_closing():
    assert switchings(np.array([0, 1, 1, 0, -1, -1, 1, 0])) == 6
    assert switchings(np.zeros(5)) == 0


def test_switchings_of_several_valves_add_up():
    one = np.array([0, 1, 1, 0, -1, 0])  # inlet opens, closes; outlet opens, closes
    assert switchings(one) == 4
    assert switchings(np.stack([one, one, np.zeros(6)], axis=1)) == 8  # per valve, summed
