"""FF+PID: its tuning rule on a linearised plant (python-control's poles are the loop's own, the
margins hold, the integral gain is the largest the margins allow), a constant disturbance the
model misses rejected to zero steady error where FF+PD keeps one, the anti-windup's bound, and
the deadband that leaves errors within the sensor's step alone."""

import warnings

import control
import jax.numpy as jnp
import numpy as np
import pytest
from _frictionless import FRICTIONLESS, linearised

from hmid.control import ForceLaw, feedforward, track, tune
from hmid.control.controllers import PD, PID
from hmid.control.integral import delayed, pid_poles, pid_transfer, tune_pid
from hmid.simulate.params import MuscleParams

DT = 1e-3
T = np.arange(0, 3001) * DT


def _linear(task: str = "position"):
    low, high = (0.004, 0.006) if task == "position" else (5.0, 15.0)
    return linearised(task, T, low, high, step_at=0.5, transition=0.25)


@pytest.mark.parametrize("task", ["position", "force"])
def test_the_pids_poles_are_python_controls_and_its_margins_hold(task):
    _, _, _, G = _linear(task)
    tuning = tune_pid(G, DT, tf=0.001)
    assert tuning.ki > 0 and tuning.stable
    # the rule's margins are control.margin's (the PD's are the closed loop's eigenvalues'):
    # on the force loop the eigenvalues give it 5.8 dB where control.margin finds no crossing
    assert tuning.control_gain_margin_db >= 6.0 and tuning.control_phase_margin_deg >= 45.0
    assert tuning.gain_margin_db >= 5.5 and tuning.phase_margin_deg >= 45.0
    ours = pid_poles(G, tuning.kp, tuning.ki, tuning.kd, tuning.tf, DT)
    ours = ours[np.abs(ours) > 1e-9]  # the last error's state adds a pole at 0
    if tuning.kd == 0:  # the derivative's filter runs unseen: python-control drops its pole
        ours = ours[~np.isclose(ours, np.exp(-DT / tuning.tf))]
    theirs = tuning.poles[np.abs(tuning.poles) > 1e-9]
    assert np.allclose(np.sort_complex(ours), np.sort_complex(theirs), atol=1e-6)
    # the largest ki: twice it breaks the margins or the loop with any kp, kd of the grid's
    C = control.ss(pid_transfer(tuning.kp, 2 * tuning.ki, tuning.kd, tuning.tf, DT))
    with warnings.catch_warnings():  # its note that it falls back to the frequency response
        warnings.simplefilter("ignore", UserWarning)
        gm, pm, _, _ = control.margin(control.series(C, control.c2d(G, DT, "zoh")))
    assert 20 * np.log10(gm) < 6.0 or pm < 45.0


def test_a_constant_disturbance_is_rejected_to_zero_steady_error():
    _, plant, ref, G = _linear("position")
    # the model's muscle pulls 0.3 N harder than the plant's: a constant force the
    # feed-forward does not know
    muscle = FRICTIONLESS.muscle.model_dump() | {"F0": FRICTIONLESS.muscle.F0 + 0.3}
    wrong = ForceLaw.of_rig(FRICTIONLESS.model_copy(update={"muscle": MuscleParams(**muscle)}))
    pd, pid = tune(G, DT, tf=0.001), tune_pid(G, DT, tf=0.001)
    ff = feedforward(plant, wrong, ref, "FF+PD", 0.03)
    error = {
        c: np.abs(track(plant, g, ff, ref, c).output - ref.y[1:])
        for c, g in (("FF+PD", pd), ("FF+PID", pid))
    }
    last, before = T[:-1] > 2.75, (T[:-1] > 1.75) & (T[:-1] < 2.0)
    assert error["FF+PD"][last].min() > 5e-5  # a PD leaves d / (1 + kp G(0)): 90 um here
    # the PID's slowest pole (a Maxwell arm's) takes it back over seconds, to nil
    assert error["FF+PID"][last].max() < 0.03 * error["FF+PD"][last].min()
    assert error["FF+PID"][last].max() < 0.8 * error["FF+PID"][before].max()
    # the linear loop says so: the input disturbance's static gain to the output is nil
    loop = control.c2d(G, DT, "zoh")
    C = pid_transfer(pid.kp, pid.ki, pid.kd, pid.tf, DT)
    assert abs(control.dcgain(control.feedback(loop, C))) < 1e-9


def test_the_anti_windup_stops_the_integral_at_the_valves_limit():
    pd = PD(*(jnp.asarray(v) for v in (0.0, 0.0, 0.01, DT)))
    pid = PID(pd, jnp.asarray(1e6), jnp.asarray(0.0), jnp.asarray(6e5))
    state = pid.init()
    ff = 5.9e5  # the feed-forward near the supply: a large error saturates at once
    efforts, integrals = [], []
    for _ in range(2000):
        state, u = pid.step(state, jnp.asarray(1.0), ff)
        efforts.append(float(ff + u))
        integrals.append(float(state[1]))
    assert max(integrals) <= 6e5 - ff + 1e6 * DT  # one step past the limit, no more
    assert integrals[-1] == integrals[100]  # frozen while saturated
    for _ in range(3):  # the error reverses: out of saturation at once
        state, u = pid.step(state, jnp.asarray(-1.0), ff)
    assert ff + float(u) < 6e5
    # without anti-windup the integral would hold 2000 samples of 1e3 Pa: 2 MPa, not 11 kPa
    assert integrals[-1] < 0.01 * 2000 * 1e6 * DT


def test_the_integral_leaves_errors_within_the_deadband_alone():
    pd = PD(*(jnp.asarray(v) for v in (0.0, 0.0, 0.01, DT)))
    pid = PID(pd, jnp.asarray(1e6), jnp.asarray(0.0), jnp.asarray(6e5), jnp.asarray(0.01))
    state = pid.init()
    for error in (0.009, -0.01, 0.005):
        state, u = pid.step(state, jnp.asarray(error), 1e5)
    assert float(u) == 0.0
    state, u = pid.step(state, jnp.asarray(0.02), 1e5)
    assert float(u) == pytest.approx(1e6 * DT * 0.02)


def test_a_dead_time_makes_the_integral_slower():
    _, _, _, G = _linear("position")
    fast, slow = (tune_pid(delayed(G, d), DT, tf=0.001) for d in (0.0, 0.08))
    assert slow.ki < fast.ki and slow.stable
