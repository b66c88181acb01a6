"""The hold (pre-roll) before a scored run: the reference holds its start, the loop runs through
it, and only what follows is scored, on the same time axis as a run without one."""

import numpy as np
import pytest
from _frictionless import FRICTIONLESS, linearised

from hmid.control import ForceLaw, feedforward, reference, track
from hmid.control.integral import tune_pid
from hmid.simulate.params import MuscleParams

DT = 1e-3
T = np.arange(0, 2001) * DT


@pytest.mark.parametrize("kind", ["step_up", "step_down", "sine", "gait"])
def test_a_held_reference_is_its_start_then_the_reference_without_one(kind):
    plain = reference(kind, T, 0.004, 0.009, step_at=0.5, transition=0.25)
    held = reference(kind, np.arange(0, 2501) * DT, 0.004, 0.009, step_at=0.5,
                     transition=0.25, hold=0.5)  # fmt: skip
    before = held.t < 0.5
    assert np.all(held.y[before] == plain.y[0])
    assert np.all(held.dy[before] == 0) and np.all(held.ddy[before] == 0)
    scored = held.scored()
    assert np.allclose(scored.t, plain.t, atol=1e-12)
    for name in ("y", "dy", "ddy"):
        assert np.allclose(getattr(scored, name), getattr(plain, name), rtol=0, atol=1e-12)
    assert np.isclose(scored.settle_from, plain.settle_from) or np.isnan(plain.settle_from)
    assert plain.scored() is plain


def test_the_hold_takes_back_the_start_up_offset_and_is_not_scored():
    # the model's muscle pulls 0.3 N harder than the plant's: at the model's hold pressure
    # the plant rests off the reference's start, as a scattered ankle does
    _, plant, ref, G = linearised("position", T, 0.004, 0.006, step_at=0.5, transition=0.25)
    muscle = FRICTIONLESS.muscle.model_dump() | {"F0": FRICTIONLESS.muscle.F0 + 0.3}
    wrong = ForceLaw.of_rig(FRICTIONLESS.model_copy(update={"muscle": MuscleParams(**muscle)}))
    pid = tune_pid(G, DT, tf=0.001)
    held = reference("step_up", np.arange(0, 3001) * DT, 0.004, 0.006, step_at=0.5,
                     transition=0.25, hold=1.0)  # fmt: skip
    cold = track(plant, pid, feedforward(plant, wrong, ref, "FF+PID", 0.03), ref, "FF+PID")
    warm = track(plant, pid, feedforward(plant, wrong, held, "FF+PID", 0.03), held, "FF+PID")
    assert np.array_equal(warm.t, cold.t) and len(warm.effort) == len(cold.effort)
    assert len(warm.pressure) == len(cold.pressure) == len(warm.output)
    assert abs(cold.output[0] - ref.y[0]) > 5e-5  # 0.1 mm off at the start (a sensor step: 0.02)
    assert abs(warm.output[0] - ref.y[0]) < 0.1 * abs(cold.output[0] - ref.y[0])
    assert warm.metrics.rmse < 0.5 * cold.metrics.rmse
