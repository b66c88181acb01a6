"""Every simulated rig keeps the one rig contract: its trajectory, its times, its errors."""

import numpy as np
import pytest

from hmid.errors import SimulationError
from hmid.simulate.dataset import RigDataset
from hmid.simulate.datasets import KINDS
from hmid.simulate.params import RigParams
from hmid.simulate.rig import SimulatedRig, Trajectory, integrate
from hmid.simulate.rigs.ankle import Ankle
from hmid.simulate.rigs.hydro_muscle import HydroMuscle
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.rigs.linear_motor import LinearMotor, LinearMotorParams, PDController

RATE = 1000.0
N = 200
RIGS = {
    "hydro_muscle": (HydroMuscle(RigParams()), {"P_cmd": np.full(N, 1.2e5)}),
    "linear_motor": (
        LinearMotor(LinearMotorParams(), PDController(), encoder_step=1e-6),
        {"r": 1e-3 * np.sin(np.linspace(0.0, 3.0, N)) ** 2},
    ),
    "ankle": (
        Ankle(),
        {"valves": np.where(np.arange(N) < N // 2, 1.0, -1.0)[:, None] * np.ones(5)},
    ),
}


@pytest.mark.parametrize("name", RIGS)
def test_the_trajectory_holds_what_the_rig_declares(name):
    rig, inputs = RIGS[name]
    assert isinstance(rig, SimulatedRig)
    traj = integrate(rig, inputs, RATE, substeps=10)
    assert list(traj) == list(rig.signals)
    assert all(len(getattr(traj, s)) == N for s in rig.signals)
    np.testing.assert_array_equal(traj.t, (np.arange(N) + rig.first_sample) / RATE)
    assert all(np.all(np.isfinite(getattr(traj, s))) for s in rig.finite if s in rig.signals)


@pytest.mark.parametrize("name", RIGS)
def test_a_run_that_leaves_finite_values_is_an_error(name):
    rig, inputs = RIGS[name]
    key = next(iter(inputs))
    bad = inputs | {key: np.r_[inputs[key][:50], np.full_like(inputs[key][50:], np.nan, float)]}
    with pytest.raises(SimulationError, match=f"the {rig.name} simulation left finite values"):
        integrate(rig, bad, RATE, substeps=10)


@pytest.mark.parametrize("name", RIGS)
def test_unknown_or_missing_inputs_are_errors(name):
    rig, inputs = RIGS[name]
    with pytest.raises(ValueError, match="reads the inputs"):
        integrate(rig, inputs | {"typo": np.zeros(N)}, RATE)
    with pytest.raises(ValueError, match="the first required"):
        integrate(rig, {}, RATE)


def test_trajectory_names_its_signals():
    traj = Trajectory(np.arange(3.0), {"x": np.zeros(3)})
    with pytest.raises(AttributeError, match="no signal 'y'"):
        _ = traj.y
    moved = traj.replace(x=np.ones(3))
    assert moved.x.sum() == 3 and traj.x.sum() == 0
    with pytest.raises(KeyError, match="'y'"):
        traj.replace(y=np.ones(3))


def test_every_rig_kind_is_a_rig_dataset():
    for model in (HydroMuscleDataset, *KINDS.values()):
        assert issubclass(model, RigDataset)
        for method in ("simulate", "column_map"):
            assert getattr(model, method) is not getattr(RigDataset, method), (model, method)
