"""Stage data sets: seeds, written files read back, the dispatcher, config errors, shipped data."""

import filecmp
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from _regenerated import differences

from hmid.errors import ConfigError
from hmid.io import load_column_map, read_log
from hmid.simulate.datasets import load_dataset_config
from hmid.simulate.reference import RandomReference
from hmid.simulate.rigs.hydro_muscle_dataset import FreeFallLog, HydroMuscleDataset
from hmid.simulate.rigs.linear_motor import LinearMotorParams
from hmid.simulate.rigs.linear_motor_dataset import (
    LinearMotorDataset,
    LinearMotorLog,
    LinearMotorSensors,
)
from hmid.simulate.write import write_dataset

ROOT = Path(__file__).resolve().parents[2]


def _config(seed=5, **kw):
    logs = kw.pop("logs", None) or (
        LinearMotorLog(name="fast", duration=4.0),
        LinearMotorLog(
            name="slow", duration=4.0, reference=RandomReference(rms=0.01, cutoff_hz=1.0)
        ),
    )
    return LinearMotorDataset(seed=seed, logs=logs, **kw)


def test_same_seed_same_log_other_name_other_seed():
    cfg = _config()
    a, b = (cfg.simulate(cfg.logs[0]) for _ in range(2))
    assert a.log.data.equals(b.log.data)
    assert cfg.seed_for(cfg.logs[0]) != cfg.seed_for(cfg.logs[1])
    renamed = LinearMotorLog(name="other", duration=4.0)
    assert not a.log.data.equals(cfg.simulate(renamed).log.data)
    assert not a.log.data.equals(_config(seed=6).simulate(cfg.logs[0]).log.data)


def test_log_does_not_depend_on_the_other_logs_or_global_state():
    cfg = _config()
    alone = _config(logs=(cfg.logs[1],))
    state = np.random.get_state()[1].copy()  # noqa: NPY002 - checking the legacy global state
    sim = cfg.simulate(cfg.logs[1])
    assert np.array_equal(np.random.get_state()[1], state)  # noqa: NPY002
    assert sim.log.data.equals(alone.simulate(alone.logs[0]).log.data)


def test_noise_options_change_only_their_channel():
    cfg = _config()
    clean = cfg.simulate(cfg.logs[0]).log
    noisy = _config(sensors=LinearMotorSensors(force_noise=0.5)).simulate(cfg.logs[0]).log
    assert np.array_equal(noisy["x"], clean["x"])
    assert np.std(noisy["u"] - clean["u"]) == pytest.approx(0.5, rel=0.1)  # 4000 draws
    jitter = _config(sensors=LinearMotorSensors(position_noise=2e-6)).simulate(cfg.logs[0])
    assert not np.array_equal(jitter.log["x"], clean["x"])
    counts = jitter.log["x"] / 1e-6
    assert np.max(np.abs(counts - np.round(counts))) < 1e-6


def test_written_set_reads_back_and_keeps_truth_apart(tmp_path):
    cfg = _config()
    paths = write_dataset(cfg, tmp_path)
    assert [p.name for p in paths] == ["fast.csv", "slow.csv"]
    index = yaml.safe_load((tmp_path / "index.yaml").read_text())["logs"]
    assert [e["kind"] for e in index] == ["dynamic", "dynamic"]
    for spec, entry in zip(cfg.logs, index, strict=True):
        sim = cfg.simulate(spec)
        log = read_log(tmp_path / entry["file"], load_column_map(tmp_path / entry["columns"]))
        assert log.channels == ("x", "u") and log.units["u"] == "N"
        np.testing.assert_allclose(log.t, sim.log.t, rtol=0, atol=1e-12)
        np.testing.assert_allclose(log["u"], sim.log["u"], rtol=1e-9, atol=1e-12)
        step = cfg.sensors.encoder_step
        np.testing.assert_array_equal(np.round(log["x"] / step), np.round(sim.log["x"] / step))
        assert np.max(np.abs(log["x"] / step - np.round(log["x"] / step))) < 1e-6
        truth = json.loads((tmp_path / f"{spec.name}.truth.json").read_text())
        assert truth["seed"] == cfg.seed_for(spec) and truth["law_truth"]["M_kg"] == 95.0
        assert truth["checks"]["balance_check"]["rms_N"] < 0.02
        assert truth["effects"] == []
        header = (tmp_path / entry["file"]).read_text().splitlines()[0]
        assert header == "t_ms,x_mm,u_N"


def test_dataset_yaml_regenerates_the_set_exactly(tmp_path):
    cfg = _config(
        stage=LinearMotorParams(Fv_negative=250.0), output={"units": {"x": "m", "u": "kN"}}
    )
    write_dataset(cfg, tmp_path / "a")
    write_dataset(load_dataset_config(tmp_path / "a/dataset.yaml"), tmp_path / "b")
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    _, mismatch, errors = filecmp.cmpfiles(tmp_path / "a", tmp_path / "b", names, shallow=False)
    assert (mismatch, errors) == ([], [])
    truth = json.loads((tmp_path / "a/fast.truth.json").read_text())
    assert truth["effects"][0]["Fv_negative"] == 250.0


def test_dispatcher_still_reads_and_writes_the_muscle_rig(tmp_path):
    path = tmp_path / "muscle.yaml"
    path.write_text("seed: 1\nlogs: [{name: ff, kind: free_fall, duration: 0.3}]\n")
    config = load_dataset_config(path)
    assert isinstance(config, HydroMuscleDataset) and isinstance(config.logs[0], FreeFallLog)
    write_dataset(config, tmp_path / "out")
    assert (tmp_path / "out/ff.truth.json").exists()
    assert (tmp_path / "out/columns-free_fall.yaml").exists()


_GOOD_LOGS = "logs: [{name: a, duration: 2}]\n"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (f"kind: linear_motor\nseed: 1\nstage: {{M: -1}}\n{_GOOD_LOGS}", r"key 'stage\.M'"),
        (f"kind: linear_motor\nseed: 1\nstagee: {{}}\n{_GOOD_LOGS}", r"'stagee': unknown key"),
        (f"kind: linear_motor\nseed: 1\nstage: {{Fv: 1, Mass: 3}}\n{_GOOD_LOGS}", r"stage\.Mass"),
        (f"kind: linear_stage\nseed: 1\n{_GOOD_LOGS}", r"key 'kind': unknown rig 'linear_stage'"),
        (f"kind: [linear_motor]\nseed: 1\n{_GOOD_LOGS}", r"key 'kind': unknown rig"),
        (f"seed: 1\nrig: {{M: -1}}\n{_GOOD_LOGS}", r"key 'rig\.M'"),
        (
            f"kind: linear_motor\nseed: 1\nstage: {{static_ratio: 0.5}}\n{_GOOD_LOGS}",
            "static_ratio",
        ),
        (f"kind: linear_motor\nseed: 1\ncontroller: {{Kp: 0}}\n{_GOOD_LOGS}", r"controller\.Kp"),
        (
            "kind: linear_motor\nseed: 1\nlogs: [{name: a, duration: 2, "
            "reference: {cutoff_hz: 600}}]\n",
            r"logs\.0\.reference\.cutoff_hz=600\.0 must be below half",
        ),
        (
            "kind: linear_motor\nseed: 1\nlogs: [{name: a, duration: 0.4}]\n",
            "fade_in=0.5 s must be shorter",
        ),
        (
            "kind: linear_motor\nseed: 1\nlogs: [{name: a, duration: 2}, {name: a, duration: 3}]\n",
            "unique",
        ),
        ("kind: linear_motor\nseed: 1\nlogs: []\n", r"key 'logs'"),
        (f"kind: linear_motor\nseed: 1\noutput: {{units: {{u: mm}}}}\n{_GOOD_LOGS}", "force unit"),
        (f"kind: linear_motor\nseed: 1\noutput: {{units: {{x: N}}}}\n{_GOOD_LOGS}", r"\[length\]"),
        (
            f"kind: linear_motor\nseed: 1\nsensors: {{encoder_step: 0}}\n{_GOOD_LOGS}",
            r"sensors\.encoder_step",
        ),
        (
            f"kind: linear_motor\nseed: 1\ncontroller: {{derivative_cutoff_hz: 800}}\n{_GOOD_LOGS}",
            "derivative_cutoff_hz=800.0 must be below half",
        ),
        ("- a\n- b\n", "must be a YAML mapping"),
    ],
)
def test_bad_configs_are_one_line_errors_naming_the_key(tmp_path, text, match):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match) as err:
        load_dataset_config(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_shipped_linear_motor_data_regenerates(tmp_path):
    # every number within _regenerated.RTOL (another CPU may round the last bits differently)
    config = load_dataset_config(ROOT / "configs/simulate/linear-motor.yaml")
    write_dataset(config, tmp_path)
    shipped = ROOT / "data/linear-motor"
    assert differences(shipped, tmp_path) == [], (
        "data/linear-motor is stale: run `make linear-motor-data`"
    )
    assert sum(p.stat().st_size for p in shipped.iterdir()) < 2.5e6
    for name in ("random-1hz", "random-2hz", "random-3hz"):
        checks = json.loads((shipped / f"{name}.truth.json").read_text())["checks"]
        assert 0 < checks["stuck_fraction"] < 0.05 and checks["stops"] > 0
        assert checks["balance_check"]["rms_N"] < 1e-3 * 20.0
