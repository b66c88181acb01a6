"""Inverse dynamics: with a perfect model of a noise-free plant the feed-forward alone tracks
to within the sensor's resolution; a model without the pressure has no inverse."""

import numpy as np
import pytest

from hmid.control import ForceLaw, MuscleRig, NotInvertible, reference, track, tune
from hmid.control.experiments import feedforward
from hmid.control.inverse import lead
from hmid.portable.freerun import Equation
from hmid.simulate.params import FrictionParams, RigParams

# The model's physics exactly: the model states friction as Coulomb's law smoothed (tanh(v/v0),
# as its free run does), the simulator as stick-slip, so the perfect model's plant has none (with
# the rig's 0.35 N of stick-slip the feed-forward alone stays within 1.5-2.5 sensor steps)
RIG = RigParams(friction=FrictionParams(F_block=0.0, F_pulley=0.0))
T = np.arange(0, 3001) * 1e-3
RANGES = {"position": (0.004, 0.009), "force": (5.0, 25.0)}


@pytest.mark.parametrize("task", ["position", "force"])
@pytest.mark.parametrize("kind", ["step_up", "step_down", "sine", "gait"])
def test_a_perfect_model_tracks_within_the_sensor_resolution_by_feed_forward_alone(task, kind):
    law = ForceLaw.of_rig(RIG)  # the plant's own physics
    plant = MuscleRig(RIG, task)  # noise-free
    ref = reference(kind, T, *RANGES[task], step_at=0.8)
    tuning = tune(plant.linear(law, ref, RIG.valve.tau), 1e-3)  # not used: no feedback
    run = track(plant, tuning, feedforward(plant, law, ref, "FF", RIG.valve.tau), ref, "FF")
    assert run.metrics.max_error <= plant.resolution  # 0.02 mm, 0.01 N


def test_the_lead_inverts_the_valves_lag_exactly():
    dt, tau = 1e-3, 0.03
    P = 1e5 + 5e4 * np.sin(np.arange(500) * dt * 7)
    u = lead(P, tau, dt)
    out = [P[0]]
    for k in range(len(u)):
        out.append(u[k] + (out[-1] - u[k]) * np.exp(-dt / tau))
    assert np.allclose(out, P, rtol=0, atol=1e-6)


def test_a_model_without_pressure_has_no_inverse():
    eq = Equation((("mono", (("x", 1),), -3000.0),), (("accel", None, 0.75),), (), 0, (), 0.002)
    with pytest.raises(NotInvertible, match="no term in P"):
        ForceLaw(eq, "P", "poly:cubic_xv")._check()
