"""Signals from simulated logs: the load-cell target is the true muscle force less nothing but
noise, a rig without a load cell explains the same force, and stops are left out."""

import numpy as np
import pytest

from hmid.balance.prepare import STOPPED_SHARE, prepare
from hmid.denoise import denoise_log
from hmid.experiment import DenoiseSection
from hmid.friction import Coulomb, FallRig, FrictionEstimate
from hmid.simulate.profiles import Sine
from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, HydroMuscleDataset

UNITS = {"x": "m", "P": "Pa", "F": "N", "v": "m/s", "a": "m/s^2", "target": "N"}
FRICTION = FrictionEstimate.known(Coulomb(), {"Fc": 0.35}, FallRig(0.75, 0.5 * 9.80665))


@pytest.fixture(scope="module")
def simulated():
    spec = DynamicLog(name="sine", duration=6.0, profile=Sine(), seed=5)
    return HydroMuscleDataset(seed=0, logs=(spec,)).simulate(spec)


def _signals(sim, rig, window_s=0.011):
    smoother, differentiator = DenoiseSection(smoother={"window_s": window_s}).build()
    log = denoise_log(sim.log, smoother, differentiator, channels=("x", "P", "F"))
    signals = prepare(rig, {"sine": [log]}, UNITS, smoother=smoother,
                      differentiator=differentiator, free_fall_law=FRICTION.friction)  # fmt: skip
    return signals, smoother


def test_the_load_cell_target_is_the_true_muscle_force_smoothed(simulated, ch4_rig):
    signals, smoother = _signals(simulated, ch4_rig)
    tr = simulated.trajectory
    truth = smoother(tr.t, tr.F_m)  # the same filter on the true force
    rows = signals.usable
    err = signals.target[rows] - truth[rows]
    # the load cell's noise 0.006 N and 0.01 N steps (0.0067 N RMS), averaged by the 3 x 11 ms
    # moving average; one friction sign error costs 2 Fc = 0.7 N, so this also says no row the
    # balance keeps has the wrong direction of motion
    assert np.sqrt(np.mean(err**2)) < 0.004
    assert 0.5 < rows.mean() < 0.95  # stops and filter edges left out, most rows kept
    assert np.all(np.sign(signals["v"][rows]) == np.sign(tr.v[rows]))


def test_without_a_load_cell_the_inertial_force_explains_the_same_balance(simulated, ch4_rig):
    parts = [{"channel": "a", "value": 0.75, "unit": "kg"}, {"value": 4.903325, "unit": "N"}]
    data = ch4_rig.model_dump(by_alias=True) | {"explained": {"name": "inertial", "parts": parts}}
    knee = type(ch4_rig).model_validate(data)
    load_cell, _ = _signals(simulated, ch4_rig, 0.025)
    inertial, _ = _signals(simulated, knee, 0.025)
    rows = load_cell.usable
    diff = inertial.target[rows] - load_cell.target[rows]
    # what remains is the acceleration estimate's noise: 0.016 mm of x noise through the second
    # difference of 3 x 25 ms moving averages (gain 784 /m: 0.0125 m/s²) times 0.75 kg
    assert np.sqrt(np.mean(diff**2)) < 0.02
    assert abs(np.mean(diff)) < 0.005


def test_rows_are_left_out_where_stopped_samples_weigh_in_the_kernel(simulated, ch4_rig):
    signals, smoother = _signals(simulated, ch4_rig)
    stopped = (np.abs(signals["raw:v"]) < 0.002).astype(float)
    share = smoother(signals["t"], stopped)
    assert not signals.usable[share > STOPPED_SHARE].any()
    assert not signals.usable[stopped > 0].any()
    inner = (
        (share == 0) & (np.arange(len(share)) > 100) & (np.arange(len(share)) < len(share) - 100)
    )
    assert signals.usable[inner].all()


def test_a_force_sensor_is_explained_by_its_own_column_held_once(simulated, ch4_rig):
    signals, _ = _signals(simulated, ch4_rig)
    assert np.shares_memory(signals["explained"], signals["F"])
    np.testing.assert_array_equal(signals["explained"], signals["F"])
