"""Sweep configs and planning: dotted-key overrides, grids, run ids, errors naming the key."""

from __future__ import annotations

import shutil

import pytest
import yaml

from hmid.errors import ConfigError
from hmid.experiment import load_experiment
from hmid.sweep import ExecutorSection, apply_overrides, load_sweep, plan_sweep


def test_overrides_set_dotted_keys_and_list_positions_without_touching_the_input():
    data = {"denoise": {"smoother": {"window_s": 0.01}}, "logs": [{"path": "a"}, {"path": "b"}]}
    out = apply_overrides(
        data, {"denoise.smoother.window_s": 0.02, "logs.1.path": "c", "fit.exclude_stuck": False}
    )
    assert out["denoise"]["smoother"]["window_s"] == 0.02
    assert [e["path"] for e in out["logs"]] == ["a", "c"]
    assert out["fit"] == {"exclude_stuck": False}  # a missing section is created
    assert data["denoise"]["smoother"]["window_s"] == 0.01 and data["logs"][1]["path"] == "b"
    whole = apply_overrides(data, {"denoise.smoother": {"mode": "causal"}})
    assert whole["denoise"]["smoother"] == {"mode": "causal"}  # replaced, not merged


@pytest.mark.parametrize(
    ("key", "message"),
    [
        ("logs.5.path", "key 'logs.5.path': logs is a list of 2 entries"),
        ("logs.path", "'path' is not a position"),
        ("denoise.smoother.window_s.x", "denoise.smoother.window_s is a value (0.01)"),
    ],
)
def test_override_paths_that_do_not_exist_are_named(key, message):
    data = {"denoise": {"smoother": {"window_s": 0.01}}, "logs": [{"path": "a"}, {"path": "b"}]}
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace(")", r"\)")):
        apply_overrides(data, {key: 1})


def test_a_grid_is_the_cartesian_product_first_key_slowest(sweep_file):
    path = sweep_file("grid", grid={"seed": [1, 2], "denoise.smoother.window_s": [0.005, 0.02]})
    sets = load_sweep(path).override_sets()
    assert [(s["seed"], s["denoise.smoother.window_s"]) for s in sets] == [
        (1, 0.005), (1, 0.02), (2, 0.005), (2, 0.02)
    ]  # fmt: skip


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"runs": [{}], "grid": {"seed": [1]}}, "give exactly one of 'runs'"),
        ({}, "give exactly one of 'runs'"),
        ({"grid": {"seed": []}}, "key 'grid.seed'"),
        ({"grid": {"denoise..window_s": [1]}}, "'denoise..window_s' is not a dotted config key"),
        ({"runs": [{}], "executor": {"kind": "process", "address": "tcp://h:1"}}, "kind 'dask'"),
        ({"runs": [{}], "executor": {"kind": "threads"}}, "key 'executor.kind'"),
        ({"runs": [{}], "exeutor": {}}, "key 'exeutor': unknown key; allowed keys are name"),
        ({"runs": [{}], "base": "nowhere.yaml"}, "key 'base': file .*nowhere.yaml does not exist"),
    ],
)
def test_sweep_config_errors_are_one_line_and_name_the_file_and_key(sweep_file, fields, message):
    path = sweep_file("bad", **fields)
    with pytest.raises(ConfigError, match=message) as err:
        load_sweep(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_an_invalid_base_experiment_is_named(workspace, sweep_file):
    base = yaml.safe_load((workspace / "experiments/base.yaml").read_text())
    (workspace / "experiments/broken.yaml").write_text(yaml.safe_dump(base | {"seed": "x"}))
    path = sweep_file("broken-base", base="../experiments/broken.yaml", runs=[{}])
    with pytest.raises(ConfigError, match=r"broken.yaml: key 'seed'"):
        load_sweep(path)


def test_command_line_executor_choices():
    pool = ExecutorSection(workers=2)
    assert pool.with_options(workers=4, scheduler=None).workers == 4
    dask = pool.with_options(workers=None, scheduler="tcp://h:8786")
    assert (dask.kind, dask.address, dask.workers) == ("dask", "tcp://h:8786", None)
    with pytest.raises(ConfigError, match="--workers and --scheduler"):
        pool.with_options(workers=2, scheduler="tcp://h:8786")
    with pytest.raises(ConfigError, match="at least 1"):
        pool.with_options(workers=0, scheduler=None)
    with pytest.raises(ConfigError, match="conflicts with the sweep's executor address"):
        dask.with_options(workers=2, scheduler=None)


def test_plan_resolves_paths_per_file_and_reports_invalid_runs(workspace, sweep_file, tmp_path):
    path = sweep_file(
        "plan",
        runs=[
            {},
            {"logs.0.path": "../data/chirp.csv"},  # relative to the sweep's folder
            {"denoise.smoother.window_s": -1.0},
            {"logs.1.path": "../data/missing.csv"},
            {"denoise.smoothr": {}},
        ],
    )
    plan = plan_sweep(load_sweep(path), tmp_path / "results")
    first, second, negative, missing, typo = plan.runs
    assert first.config["logs"][0]["path"] == str(workspace / "data/sine.csv")
    assert second.config["logs"][0]["path"] == str(workspace / "data/chirp.csv")
    assert len({first.run_id, second.run_id}) == 2 and len(first.run_id) == 12
    assert negative.run_id is None
    assert negative.error.startswith("run 3: key 'denoise.smoother.window_s': input should be")
    assert missing.error.startswith(
        f"run 4: key 'logs.1.path': file {workspace / 'data/missing.csv'} does not exist"
    )
    assert "key 'denoise.smoothr': unknown key" in typo.error
    assert [r.number for r in plan.pending] == [1, 2]
    assert plan.folder == (tmp_path / "results/plan").resolve() and not plan.folder.exists()
    # the config a worker writes stands alone: its log paths work from any folder
    written = tmp_path / "elsewhere/config.yaml"
    written.parent.mkdir()
    written.write_text(plan.task(first).header + yaml.safe_dump(first.config))
    assert load_experiment(written).logs[0].path == workspace / "data/sine.csv"


def test_run_ids_follow_the_config_and_the_data(workspace, sweep_file, tmp_path):
    path = sweep_file("ids", grid={"denoise.smoother.window_s": [0.005, 0.02]})
    ids = [r.run_id for r in plan_sweep(load_sweep(path), tmp_path).runs]
    assert ids == [r.run_id for r in plan_sweep(load_sweep(path), tmp_path / "other").runs]
    copy = tmp_path / "data"
    shutil.copytree(workspace / "data", copy)
    (copy / "ff2.csv").write_text((copy / "ff2.csv").read_text() + "\n")  # same rows, new bytes
    moved = sweep_file("ids-copy", grid={"denoise.smoother.window_s": [0.005, 0.02]})
    data = yaml.safe_load(moved.read_text())
    data["grid"]["logs.3.path"] = [str(copy / "ff2.csv")]
    moved.write_text(yaml.safe_dump(data))
    changed = [r.run_id for r in plan_sweep(load_sweep(moved), tmp_path).runs]
    assert not set(changed) & set(ids)


def test_two_runs_with_the_same_experiment_are_an_error(sweep_file, tmp_path):
    path = sweep_file("twice", runs=[{}, {"denoise.smoother.window_s": 0.011}])  # the default
    with pytest.raises(ConfigError, match="runs 1 and 2 give the same experiment"):
        plan_sweep(load_sweep(path), tmp_path)
