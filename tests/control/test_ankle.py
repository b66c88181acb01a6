"""The ankle's adaptor: the perfect model's feed-forward tracks within the potentiometer's step,
the PD's closed-loop poles on the linearised ankle are python-control's and the nonlinear ankle
answers a small step as the linear loop predicts, recruitment picks the fewest fibres, and the
fibres' data sets mount the ankle's own muscles on the Ch. 4 rig."""

import math
from pathlib import Path

import control
import numpy as np
import pytest
import yaml

from hmid.config import load_yaml_model
from hmid.control import feedforward, reference, track, tune
from hmid.control.actuation import Switching
from hmid.control.ankle import AnkleRig, FibreLaws, full_torque, joint_stiffness, recruit
from hmid.control.ankle_study import ankle_plant, scatter_fibres
from hmid.control.config import load_control_config
from hmid.control.tuning import closed_loop_poles, closed_poles, pd_transfer
from hmid.errors import ConfigError
from hmid.simulate.rigs.ankle_params import AnkleParams
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.valves import ProportionalValve

ROOT = Path(__file__).resolve().parents[2]
DT = 1e-3
T = np.arange(0, 2501) * DT
# the model's joint friction is Coulomb's smoothed, the plant's stick-slip: the perfect model's
# plant has none (noise-free: the potentiometer's quantisation is its only sensor error)
FRICTIONLESS = AnkleParams(coulomb=0.0, valve=ProportionalValve())
ALL = (True,) * 5


def _plant(params: AnkleParams = FRICTIONLESS, engaged=ALL) -> AnkleRig:
    return AnkleRig(params, engaged).proportional(ProportionalValve())


@pytest.mark.parametrize("kind", ["step_up", "step_down", "sine", "gait"])
def test_a_perfect_model_tracks_within_the_potentiometer_by_feed_forward_alone(kind):
    plant, law = _plant(), FibreLaws.perfect(FRICTIONLESS)
    ref = reference(kind, T, 0.0, math.radians(20), step_at=0.5, transition=0.4)
    tuning = tune(plant.linear(law, ref, 0.03), DT, tf=0.01)  # not used: no feedback
    run = track(plant, tuning, feedforward(plant, law, ref, "FF", 0.03), ref, "FF")
    assert run.metrics.max_error <= plant.resolution  # 0.29 deg
    assert np.ptp(run.output) > math.radians(15)  # it moved


def test_fibres_unlike_each_other_their_own_physics_tracks_with_the_slack_ones_left_out():
    # a build's scatter (draw 3 of the ankle study's seed) at one common pressure leaves three
    # of the five engaged fibres slack by their own physics (-11 to -15 N): a balance that
    # summed them as pushing missed by 1.3 deg under FF+PD with each fibre's own model
    scattered = scatter_fibres(FRICTIONLESS, 4, 20170427)[3]
    params = FRICTIONLESS.model_copy(update={"fibres": scattered})
    plant, law = _plant(params), FibreLaws.perfect(params)
    ref = reference("sine", T, 0.0, math.radians(20), step_at=0.5, transition=0.4)
    tuning = tune(plant.linear(law, ref, 0.03), DT, tf=0.01)  # not used: no feedback
    run = track(plant, tuning, feedforward(plant, law, ref, "FF", 0.03), ref, "FF")
    assert run.metrics.max_error <= plant.resolution  # 0.29 deg
    assert np.ptp(run.output) > math.radians(15)


def _linear(engaged=ALL):
    plant, law = _plant(engaged=engaged), FibreLaws.perfect(FRICTIONLESS)
    ref = reference("step_up", T, math.radians(10), math.radians(10.5), step_at=0.2,
                    transition=0.05)  # fmt: skip
    return plant, law, ref, plant.linear(law, ref, 0.03)


@pytest.mark.parametrize("engaged", [ALL, (False, False, True, True, False)])
def test_the_pd_closed_loop_poles_on_the_linearised_ankle(engaged):
    _, _, _, G = _linear(engaged)
    assert np.squeeze(G.dcgain()) < 0  # more pressure, more dorsiflexion
    tuning = tune(G, DT, tf=0.01)
    assert tuning.kp < 0 and tuning.stable
    assert tuning.gain_margin_db >= 6.0 - 1e-9 and tuning.phase_margin_deg >= 45.0 - 1e-9
    ours = closed_poles(G, tuning.kp, tuning.kd, tuning.tf, DT)
    ours = ours[np.abs(ours) > 1e-9]
    if tuning.kd == 0:  # the derivative's filter runs unseen: python-control drops its pole
        ours = ours[~np.isclose(ours, np.exp(-DT / tuning.tf))]
    theirs = closed_loop_poles(G, tuning.kp, tuning.kd, tuning.tf, DT)
    theirs = theirs[np.abs(theirs) > 1e-9]
    assert np.allclose(np.sort_complex(ours), np.sort_complex(theirs), atol=1e-6)
    assert np.all(np.abs(theirs) < 1.0)


def test_the_ankle_answers_a_small_step_as_the_linear_loop_predicts():
    plant, law, ref, G = _linear()
    plant = AnkleRig(FRICTIONLESS, ALL, sensor_step=0.0).proportional(ProportionalValve())
    tuning = tune(G, DT, tf=0.01)
    run = track(plant, tuning, feedforward(plant, law, ref, "PD", 0.03), ref, "PD")
    loop = control.feedback(pd_transfer(tuning.kp, tuning.kd, tuning.tf, DT)
                            * control.c2d(G, DT, "zoh"), 1)  # fmt: skip
    linear = control.forced_response(loop, T[:-1], ref.y[:-1] - ref.y[0]).outputs
    rig = run.output - ref.y[0]
    assert np.max(np.abs(linear)) > 0.1 * (ref.y[-1] - ref.y[0])  # it moves
    assert np.max(np.abs(rig[:-1] - linear[1:])) < 0.1 * np.max(np.abs(linear))


def test_recruitment_takes_the_fewest_fibres_that_reach_the_torque_and_stiffness():
    plant, law = _plant(), FibreLaws.perfect(FRICTIONLESS)
    angles = np.radians([0.0, 20.0])
    one = recruit(plant, law, 1.0, angles)
    assert sum(one) == 1 and one[2]  # a soleus: the strongest single fibre
    every = full_torque(plant, law, range(5), angles).min()
    assert sum(recruit(plant, law, 0.9 * every, angles)) == 5
    more = [sum(recruit(plant, law, f * every, angles)) for f in (0.1, 0.3, 0.6, 0.9)]
    assert more == sorted(more)
    with pytest.raises(ValueError, match="beyond every fibre"):
        recruit(plant, law, 1.1 * every, angles)
    stiffest = joint_stiffness(plant, law, range(5), angles).min()
    assert (
        joint_stiffness(plant, law, (2, 3), angles).min()
        > joint_stiffness(plant, law, (2,), angles).max()
    )  # a superset is stiffer (thesis Ch. 6)
    by_stiffness = [sum(recruit(plant, law, 0.0, angles, f * stiffest)) for f in (0.1, 0.5, 0.9)]
    assert by_stiffness == sorted(by_stiffness) and by_stiffness[-1] == 5


def test_disengaged_fibres_stay_filled_and_on_off_valves_switch_per_fibre():
    engaged = (True, False, True, False, False)
    act = _plant(engaged=engaged).actuation
    _, out = act.realise(act.init(), 2e5, {"P": np.zeros(5)})
    assert np.allclose(out["valves"], [2e5, 6e5, 2e5, 6e5, 6e5])
    on_off = AnkleRig(AnkleParams(), engaged, realisation=Switching(band=1e3)).actuation
    measured = {"P": np.array([1e5, 0.0, 3e5, 0.0, 0.0])}
    _, out = on_off.realise(on_off.init(), 2e5, measured)
    assert np.allclose(out["valves"], [1.0, 1.0, -1.0, 1.0, 1.0])  # fill, idle, vent, idle..
    with pytest.raises(ValueError, match="one flag per active fibre"):
        AnkleRig(AnkleParams(), (True, False))


@pytest.mark.parametrize("fibre", ["gastrocnemius", "soleus"])
def test_the_fibre_data_sets_mount_the_ankles_own_muscle(fibre):
    dataset = load_yaml_model(ROOT / f"configs/simulate/fibre-{fibre}.yaml", HydroMuscleDataset)
    build = getattr(AnkleParams(), fibre).spec.params()
    for name, value in build.model_dump().items():
        assert getattr(dataset.rig.muscle, name) == pytest.approx(value, rel=1e-12), name


def test_a_config_recruits_for_its_torque_or_engages_the_named_fibres(tmp_path):
    shipped = ROOT / "configs/control/ankle.yaml"
    config = yaml.safe_load(shipped.read_text())
    config["ankle"]["plant"] = str(shipped.parent / "ankle-plant.yaml")
    path = tmp_path / "ankle.yaml"
    named = config | {"ankle": config["ankle"] | {"engaged": ["soleus 2"]}}
    path.write_text(yaml.safe_dump(named))
    assert ankle_plant(load_control_config(path)).engaged == (False, False, False, True, False)
    torque = config | {"ankle": {**config["ankle"], "engaged": None, "torque": 1.0}}
    path.write_text(yaml.safe_dump(torque))
    params = AnkleParams()
    plant = ankle_plant(load_control_config(path), FibreLaws.perfect(params))
    assert sum(plant.engaged) == 1
    bad = config | {"ankle": config["ankle"] | {"engaged": ["tibialis 1"]}}
    path.write_text(yaml.safe_dump(bad))
    with pytest.raises(ConfigError, match="not active fibres"):
        load_control_config(path)
