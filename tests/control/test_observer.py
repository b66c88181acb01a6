"""FF+DOB: the disturbance observer's tuning rule on a linearised plant (the margins hold, the
loop integrates, its estimate of a disturbance the model misses is that disturbance), a constant
force the model misses rejected to within a sensor step where FF+PD keeps 4.5 steps of it, and
the bound on the estimate at the valves' limits."""

import control
import jax.numpy as jnp
import numpy as np
import pytest
from _frictionless import FRICTIONLESS, linearised

from hmid.control import ForceLaw, feedforward, track, tune
from hmid.control.controllers import PD
from hmid.control.observer import (
    DOB,
    observer,
    observer_transfer,
    relative_degree,
    tune_dob,
)
from hmid.control.plant import MuscleRig
from hmid.control.tuning import pd_gain_margin_db
from hmid.simulate.params import MuscleParams

DT = 1e-3
T = np.arange(0, 3001) * DT


@pytest.fixture(scope="module")
def tuned():
    _, plant, ref, G = linearised("position", T, 0.004, 0.006, step_at=0.5, transition=0.25)
    pd = tune(G, DT, tf=0.001)
    return plant, ref, G, pd, tune_dob(G, pd, DT)


def test_the_observers_loop_keeps_the_margins_and_integrates(tuned):
    _, _, G, pd, dob = tuned
    assert relative_degree(G) == 3 and dob.observer.order == 4  # Q G^-1 strictly proper
    assert dob.stable and dob.phase_margin_deg >= 45.0
    # the PD alone has at least 6 dB by its eigenvalues: the observer costs at most half a dB
    assert pd_gain_margin_db(G, pd.kp, pd.kd, pd.tf, DT) == pytest.approx(pd.gain_margin_db)
    assert dob.gain_margin_db >= min(6.0, pd.gain_margin_db) - 0.5 - 1e-9
    assert 1.0 < dob.observer.bandwidth_hz < 20.0
    # with Q(0) = 1 the feedback integrates: an input disturbance's static gain to the output
    # is nil (a PD's is G(0) / (1 + kp G(0)))
    K = observer_transfer(dob.observer, pd.kp, pd.kd, pd.tf, DT)
    sampled = control.c2d(G, DT, "zoh")
    assert abs(control.dcgain(control.feedback(sampled, K))) < 1e-6 * abs(control.dcgain(G))


def test_the_estimate_of_a_constant_input_disturbance_is_that_disturbance(tuned):
    _, _, G, _, dob = tuned
    # the plant's open-loop response to u_fb = 0 and a disturbance of 1 kPa: the observer's
    # estimate from the error alone goes to 1 kPa
    obs = dob.observer
    d = 1e3
    e = -control.forced_response(control.c2d(G, DT, "zoh"), T, np.full(len(T), d)).outputs
    x, estimate = np.zeros(obs.A.shape[0]), []
    for ek in np.asarray(e).reshape(-1):
        estimate.append(float(obs.C[0] @ x))
        x = obs.A @ x + obs.B @ np.array([ek, 0.0])
    assert estimate[-1] == pytest.approx(d, rel=1e-3)


@pytest.mark.parametrize("sensor_step", [0.0, None])  # exact, and the IR sensor's 0.02 mm
def test_a_constant_force_the_model_misses_is_rejected_within_a_sensor_step(tuned, sensor_step):
    plant, ref, _, pd, dob = tuned
    plant = MuscleRig(FRICTIONLESS, "position", sensor_step=sensor_step)
    # the model's muscle pulls 0.3 N harder than the plant's: a force the feed-forward lacks
    muscle = FRICTIONLESS.muscle.model_dump() | {"F0": FRICTIONLESS.muscle.F0 + 0.3}
    wrong = ForceLaw.of_rig(FRICTIONLESS.model_copy(update={"muscle": MuscleParams(**muscle)}))
    ff = feedforward(plant, wrong, ref, "FF+PD", 0.03)
    error = {c: np.abs(track(plant, g, ff, ref, c).output - ref.y[1:])
             for c, g in (("FF+PD", pd), ("FF+DOB", dob))}  # fmt: skip
    last, step = T[:-1] > 2.5, 2e-5
    assert error["FF+PD"][last].min() > 4 * step  # d / (1 + kp G(0)): 90 um
    assert error["FF+DOB"][last].max() < 0.1 * step  # within 1 um


def test_the_estimate_stays_within_the_valves_span():
    pd = PD(*(jnp.asarray(v) for v in (0.0, 0.0, 0.01, DT)))
    _, _, _, G = linearised("position", T, 0.004, 0.006, step_at=0.5, transition=0.25)
    obs = observer(G, 5.0, DT)
    dob = DOB(pd, *(jnp.asarray(m) for m in (obs.A, obs.B, obs.C, 0.0, 6e5)))
    state = dob.init()
    for _ in range(3000):  # an error no effort within the valves' span takes back
        state, u = dob.step(state, jnp.asarray(1e-3), 3e5)
        assert abs(float(u)) <= 6e5 + 1e-6
