"""Bad simulation configs are one-line ConfigErrors naming the key, never tracebacks or bad data."""

import json

import numpy as np
import pytest

from hmid.config import load_yaml_model
from hmid.errors import ConfigError
from hmid.io import load_column_map, read_log
from hmid.simulate.params import RigParams, ValveParams
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.write import write_dataset

GOOD_LOG = "{name: a, kind: dynamic, duration: 1, profile: {kind: sine}}"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (f"seed: -1\nlogs: [{GOOD_LOG}]\n", r"'seed': input should be greater than or equal"),
        (
            f"seed: 1\nrig: {{muscle: {{F0: .nan}}}}\nlogs: [{GOOD_LOG}]\n",
            r"rig.muscle.F0': input should be a fin",
        ),
        (
            "seed: 1\nlogs: [{name: a, kind: dynamic, duration: .inf, profile: {kind: sine}}]\n",
            r"'logs.0.duration'",
        ),
        (f"seed: 1\noutput: {{units: {{P: furlong}}}}\nlogs: [{GOOD_LOG}]\n", r"'output.units'"),
        (f"seed: 1\noutput: {{units: {{x: kPa}}}}\nlogs: [{GOOD_LOG}]\n", r"\[length\]"),
        ("seed: 1\nlogs: [{name: f, kind: free_fall, duration: 1, x0: 0.5}]\n", "x0=0.5"),
        ("seed: 1\nlogs: [{name: f, kind: free_fall, duration: 0.3, release: 0.4}]\n", "release"),
        (
            "seed: 1\nlogs: [{name: a, kind: dynamic, duration: 0.001, profile: {kind: sine}}]\n",
            "fewer than 10 samples",
        ),
        ("seed: 1\nlogs: [{kind: relaxation, name: r, params: {P0: 0}}]\n", r"params.P0"),
        (
            "seed: 1\nlogs: [{name: a, kind: dynamic, duration: 1, profile: {kind: cycles, "
            "period: 1, duty: 0.9, ramp: 0.2}}]\n",
            "must not exceed the period",
        ),
        (
            "seed: 1\nlogs: [{name: a, kind: dynamic, duration: 1, profile: {kind: steps, "
            "levels: []}}]\n",
            r"profile.levels",
        ),
        (f"seed: 1\nseed: 2\nlogs: [{GOOD_LOG}]\n", "key 'seed' is given twice"),
        (
            f"seed: 1\nsubsteps: 1\nrig: {{valve: {{tau: 0.001}}}}\nlogs: [{GOOD_LOG}]\n",
            "raise substeps",
        ),
    ],
)
def test_bad_dataset_configs(tmp_path, text, match):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match) as err:
        load_yaml_model(path, HydroMuscleDataset)
    assert "\n" not in str(err.value)


def test_output_into_a_file_is_an_error(tmp_path):
    path = tmp_path / "set.yaml"
    path.write_text(f"seed: 1\nlogs: [{GOOD_LOG}]\n")
    (tmp_path / "taken").write_text("x")
    with pytest.raises(Exception, match="not a folder"):
        write_dataset(load_yaml_model(path, HydroMuscleDataset), tmp_path / "taken")


def test_fast_valve_is_stable_even_below_one_substep():
    # The valve lag is stepped exactly, so a time constant shorter than a substep cannot ring.
    rig = RigParams(valve=ValveParams(tau=1e-5, slew=1e9))
    P_cmd = np.where(np.arange(400) < 100, 1.0e5, 1.2e5)
    traj = integrate(HydroMuscle(rig), {"P_cmd": P_cmd}, 1000.0, substeps=20)
    np.testing.assert_allclose(traj.P[150:], 1.2e5, rtol=1e-9)
    assert np.all(np.diff(traj.P) >= 0)


@pytest.mark.parametrize("units", [{"x": "m", "P": "bar", "F": "kN"}, {"x": "mm", "P": "psi"}])
def test_saturation_is_flagged_in_any_output_unit(tmp_path, units):
    # An aggressive random profile drives the load cell to its rails; the written column map
    # must flag those samples whatever units the logger writes in.
    units_yaml = json.dumps(units)
    path = tmp_path / "set.yaml"
    path.write_text(
        f"seed: 3\noutput: {{units: {units_yaml}}}\nlogs: [{{name: r, kind: dynamic, "
        "duration: 15, profile: {kind: random_levels, low: 30000, high: 260000, hold_min: 0.3}}]\n"
    )
    config = load_yaml_model(path, HydroMuscleDataset)
    write_dataset(config, tmp_path / "out")
    truth = json.loads((tmp_path / "out/r.truth.json").read_text())
    railed = truth["checks"]["samples_at_adc_rails"]["F"]
    assert railed > 0
    with pytest.warns(UserWarning, match="rails"):
        log = read_log(
            tmp_path / "out/r.csv", load_column_map(tmp_path / "out/columns-dynamic.yaml")
        )
    assert any(f"{railed} sample(s) at the sensor rails" in flag for flag in log.flags)
