"""The closed loop runs the rig's own sample step: a controller that passes its reference
through is the open-loop run, and feedback reaches its set-point."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from hmid.simulate.params import RigParams
from hmid.simulate.rig import closed_loop, integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle

N = 2000
OUT0 = {"P": 1e5, "x": 0.0, "v": 0.0, "a": 0.0, "F_m": 0.0, "friction": 0.0, "q": 0.0,
        "stuck": True, "contact": False, "tension_min": 0.0}  # fmt: skip


class PassThrough(eqx.Module):
    def init(self):
        return jnp.zeros(())

    def step(self, state, measured, reference):
        return state, {"P_cmd": reference}


class PI(eqx.Module):
    kp: float
    ki: float
    dt: float

    def init(self):
        return jnp.zeros(())

    def step(self, integral, measured, reference):
        error = reference - measured["x"]
        integral = integral + error * self.dt
        return integral, {"P_cmd": jnp.clip(1e5 + self.kp * error + self.ki * integral, 0, 1.2e6)}


def test_a_controller_that_passes_its_reference_is_the_open_loop_run():
    rig = HydroMuscle(RigParams())
    P = 1.0e5 + 5.0e4 * np.sin(np.linspace(0, 6, N))
    open_ = integrate(rig, {"P_cmd": P}, 1000.0)
    closed, commands = closed_loop(
        rig, PassThrough(), P, 1000.0, initial_inputs={"P_cmd": P},
        initial_outputs=OUT0,
    )  # fmt: skip
    np.testing.assert_allclose(commands["P_cmd"], P)
    for name in ("x", "v", "P", "F_m"):
        np.testing.assert_allclose(
            getattr(closed, name), getattr(open_, name), rtol=1e-9, atol=1e-9
        )


def test_feedback_reaches_its_set_point():
    reference = np.where(np.arange(N) > 300, 0.012, 0.008)
    traj, _ = closed_loop(
        HydroMuscle(RigParams()), PI(5e6, 5e7, 1e-3), reference, 1000.0,
        initial_inputs={"P_cmd": np.full(N, 1e5)}, initial_outputs=OUT0,
    )  # fmt: skip
    assert traj.x[-1] == pytest.approx(0.012, abs=1e-4)
    assert abs(traj.x[-1] - 0.012) < abs(traj.x[1000] - 0.012) < 1e-3


def test_the_controller_must_be_told_every_output_it_may_read():
    with pytest.raises(ValueError, match="initial_outputs lacks"):
        closed_loop(
            HydroMuscle(RigParams()), PassThrough(), np.zeros(10), 1000.0,
            initial_inputs={"P_cmd": np.full(10, 1e5)}, initial_outputs={"x": 0.0},
        )  # fmt: skip


def test_the_rig_says_what_the_controller_reads_first_and_a_rig_without_it_says_so():
    from hmid.simulate.rigs.linear_motor import LinearMotor, LinearMotorParams, PDController

    rig = HydroMuscle(RigParams())
    P = np.full(N, 1.2e5)
    start = rig.initial_outputs({"P_cmd": P}, 1000.0)
    open_ = integrate(rig, {"P_cmd": P}, 1000.0)
    assert start["x"] == pytest.approx(open_.x[0], abs=1e-9)  # at rest at the equilibrium
    default, _ = closed_loop(rig, PassThrough(), P, 1000.0, initial_inputs={"P_cmd": P})
    np.testing.assert_allclose(default.x, open_.x, rtol=0, atol=1e-12)
    stage = LinearMotor(LinearMotorParams(), PDController(), encoder_step=1e-6)
    with pytest.raises(NotImplementedError, match="does not run in a closed loop"):
        closed_loop(stage, PassThrough(), np.zeros(10), 1000.0,
                    initial_inputs={"r": np.zeros(10)})  # fmt: skip
