"""Data sets: determinism from the seed, truth kept apart, files read back, demo reproducible."""

import filecmp
import json
from pathlib import Path

import numpy as np
import pytest
from _regenerated import differences

from hmid.config import load_yaml_model
from hmid.errors import ConfigError, HmidError
from hmid.io import load_column_map, read_log
from hmid.simulate.params import Glitches, Sensors
from hmid.simulate.profiles import Chirp, RandomLevels
from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, FreeFallLog, HydroMuscleDataset
from hmid.simulate.write import write_dataset

ROOT = Path(__file__).resolve().parents[2]


def _config(**kw):
    logs = (
        DynamicLog(name="rand", duration=3.0, profile=RandomLevels(low=8e4, high=1.6e5)),
        DynamicLog(name="chirp", duration=3.0, profile=Chirp()),
        FreeFallLog(name="ff", duration=0.3),
    )
    return HydroMuscleDataset(seed=kw.pop("seed", 11), logs=logs, **kw)


def test_same_seed_same_log_other_seed_other_noise():
    a, b, c = (cfg.simulate(cfg.logs[0]) for cfg in (_config(), _config(), _config(seed=12)))
    assert a.log.data.equals(b.log.data)
    assert not a.log.data.equals(c.log.data)


def test_log_seed_does_not_depend_on_the_other_logs():
    cfg = _config()
    alone = HydroMuscleDataset(seed=11, logs=(cfg.logs[1],))
    assert cfg.simulate(cfg.logs[1]).log.data.equals(alone.simulate(alone.logs[0]).log.data)


def test_no_global_random_state_is_used():
    state = np.random.get_state()[1].copy()  # noqa: NPY002 - checking the legacy global state
    cfg = _config()
    cfg.simulate(cfg.logs[0])
    assert np.array_equal(np.random.get_state()[1], state)  # noqa: NPY002


def test_written_set_reads_back_and_keeps_truth_apart(tmp_path):
    cfg = _config()
    write_dataset(cfg, tmp_path)
    index = (tmp_path / "index.yaml").read_text()
    for spec in cfg.logs:
        sim = cfg.simulate(spec)
        entry = next(
            e for e in __import__("yaml").safe_load(index)["logs"] if e["name"] == spec.name
        )
        log = read_log(tmp_path / entry["file"], load_column_map(tmp_path / entry["columns"]))
        for channel in sim.log.channels:
            # written in ms/kPa/mm with 10 significant digits: back to SI within rounding
            np.testing.assert_allclose(log[channel], sim.log[channel], rtol=1e-9, atol=1e-12)
        assert set(log.channels) == {"x", "F"} | ({"P"} if spec.kind == "dynamic" else set())
        truth = json.loads((tmp_path / f"{spec.name}.truth.json").read_text())
        assert truth["seed"] == cfg.seed_for(spec)
        assert truth["friction_truth"]["coulomb_N"] == pytest.approx(0.35)
        header = (tmp_path / entry["file"]).read_text().splitlines()[0]
        assert "truth" not in header and "coulomb" not in header


def test_writing_twice_gives_identical_files(tmp_path):
    cfg = _config()
    write_dataset(cfg, tmp_path / "a")
    write_dataset(cfg, tmp_path / "b")
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    _, mismatch, errors = filecmp.cmpfiles(tmp_path / "a", tmp_path / "b", names, shallow=False)
    assert mismatch == [] and errors == []


def test_output_folder_is_never_overwritten(tmp_path):
    cfg = _config()
    write_dataset(cfg, tmp_path)
    with pytest.raises(HmidError, match="not empty"):
        write_dataset(cfg, tmp_path)


def test_glitches_drop_rows_and_add_spikes():
    sensors = Sensors(glitches=Glitches(spike_rate=0.01, dropout_rate=0.02))
    cfg = _config(sensors=sensors)
    sim = cfg.simulate(cfg.logs[1])
    n = 3000
    dropped = sim.truth["checks"]["dropped_samples"]
    assert len(sim.log) == n - dropped
    assert abs(dropped - 0.02 * n) < 4 * np.sqrt(0.02 * n)  # binomial, 4 sigma
    clean = _config().simulate(_config().logs[1])
    kept = np.isin(clean.log.t, sim.log.t)
    jumps = np.abs(sim.log["F"] - clean.log["F"][kept]) > 0.5
    assert 0.003 * n < jumps.sum() < 0.02 * n


def test_shipped_demo_data_regenerates(tmp_path):
    # every number within _regenerated.RTOL (another CPU may round the last bits differently)
    config = load_yaml_model(ROOT / "configs/simulate/demo.yaml", HydroMuscleDataset)
    write_dataset(config, tmp_path)
    shipped = ROOT / "data/demo"
    assert differences(shipped, tmp_path) == [], "data/demo is stale: run `make demo-data`"
    assert sum(p.stat().st_size for p in shipped.iterdir()) < 4e6


def test_unknown_keys_and_bad_values_name_the_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("seed: 1\nlogs: []\nrig: {M: -1}\n")
    with pytest.raises(ConfigError, match=r"rig\.M"):
        load_yaml_model(bad, HydroMuscleDataset)
    bad.write_text("seed: 1\nlogs: []\nsensor: {}\n")
    with pytest.raises(ConfigError, match="'sensor': unknown key"):
        load_yaml_model(bad, HydroMuscleDataset)
    bad.write_text(
        "seed: 1\nlogs: [{name: a, kind: free_fall, duration: 1}, "
        "{name: a, kind: free_fall, duration: 1}]\n"
    )
    with pytest.raises(ConfigError, match="unique"):
        load_yaml_model(bad, HydroMuscleDataset)
