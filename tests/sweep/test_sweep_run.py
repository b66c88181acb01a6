"""Sweeps executed for real: a local process pool and a local Dask cluster (scheduler and worker
processes started here), a failed run that does not stop the others, resume, interruption."""

from __future__ import annotations

import json
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pandas as pd
import pytest

from hmid.cli import main
from hmid.experiment import load_experiment
from hmid.sweep import execute, load_sweep, plan_sweep, read_done
from pipelines.sweep import run as run_sweep

RUNS = [
    {},
    {"denoise.smoother.window_s": 0.021},
    {"logs.0.path": "../garbage.csv"},  # exists but is no log: fails in its worker
    {"split.validation_fraction": 0.4},
]


@pytest.fixture(scope="module")
def pool():
    """A process pool that several tests share (the sweep leaves a given executor open)."""
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as executor:
        yield executor


@pytest.fixture(scope="module")
def pool_sweep(sweep_file, tmp_path_factory):
    """The four runs on the local process pool that the config asks for (2 workers)."""
    path = sweep_file("pool", runs=RUNS, executor={"kind": "process", "workers": 2})
    results = tmp_path_factory.mktemp("results")
    return path, results, run_sweep(path, results=results)


def _check_table(outcome, workspace):
    table = pd.read_csv(outcome.table)
    assert list(table["#"]) == [1, 2, 3, 4]
    assert [s.split(":")[0] for s in table["status"]] == ["ok", "ok", "failed", "ok"]
    failed = table["status"][2]
    assert failed.startswith(f"failed: {workspace / 'garbage.csv'}: column ") and "\n" not in failed
    ok = table[table["status"] == "ok"]
    assert (ok["best model"] == "poly:quadratic_xv").all()
    assert (ok["RMSE poly:quadratic_xv [N]"] > 0).all() and (ok["friction Fc [N]"] > 0).all()
    assert table.columns[:3].tolist() == ["#", "run id", "denoise.smoother.window_s"]
    assert outcome.count("ok") == 3 and outcome.count("failed") == 1
    return table


def test_process_pool_sweep_reports_the_failed_run_and_finishes_the_others(pool_sweep, workspace):
    _, results, outcome = pool_sweep
    table = _check_table(outcome, workspace)
    assert outcome.folder == (results / "pool").resolve()
    assert (outcome.ran, outcome.skipped) == (4, 0)
    assert "garbage.csv" in outcome.markdown.read_text()
    for run_id, folder in zip(table["run id"], table["folder"], strict=True):
        record = read_done(outcome.folder, run_id)
        assert record is not None and record.worker.split(":")[1] != str(os.getpid())
        config = load_experiment(outcome.folder / "runs" / run_id / "config.yaml")  # stands alone
        window = record.overrides.get("denoise.smoother.window_s", 0.011)
        assert config.denoise.smoother.window_s == window
        if record.status == "ok":
            metrics = json.loads((outcome.folder / folder / "metrics.json").read_text())
            assert metrics["best_model"] == record.summary["best model"]
            assert (outcome.folder / folder / "report.html").is_file()


def test_a_real_local_dask_cluster_gives_the_same_table(pool_sweep, workspace, tmp_path):
    distributed = pytest.importorskip("distributed")
    path, _, pool_outcome = pool_sweep
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        worker_pids = set(client.run(os.getpid).values())
        outcome = run_sweep(path, results=tmp_path, scheduler=cluster.scheduler_address)
    table = _check_table(outcome, workspace)
    pids = {int(read_done(outcome.folder, i).worker.split(":")[1]) for i in table["run id"]}
    assert pids <= worker_pids and os.getpid() not in pids
    numbers = ["run id", "best R² (held-out)", "RMSE poly:quadratic_xv [N]", "friction Fc [N]"]
    pd.testing.assert_frame_equal(table[numbers], pd.read_csv(pool_outcome.table)[numbers])


def test_a_limited_sweep_resumes_where_it_stopped(pool_sweep, pool, tmp_path):
    path, _, _ = pool_sweep
    first = run_sweep(path, results=tmp_path, executor=pool, limit=2)
    assert (first.ran, first.count("ok"), first.count("pending")) == (2, 2, 2)
    done = sorted((first.folder / "done").iterdir())
    stamps = {p.name: p.stat().st_mtime_ns for p in done}
    assert len(done) == 2
    finished = []
    second = run_sweep(path, results=tmp_path, executor=pool, progress=finished.append)
    assert (second.ran, second.skipped) == (2, 2)
    assert {f"{r.run_id}.json" for r in finished}.isdisjoint(stamps)
    assert {p.name: p.stat().st_mtime_ns for p in done} == stamps  # not written again
    assert second.count("ok") == 3 and second.count("failed") == 1
    again = run_sweep(path, results=tmp_path)
    assert (again.ran, again.skipped) == (0, 4)


def test_retry_failed_plans_only_the_failed_run(pool_sweep):
    path, results, outcome = pool_sweep
    plan = plan_sweep(load_sweep(path), results, retry_failed=True)
    failed = outcome.frame["run id"][outcome.frame["status"].str.startswith("failed")]
    assert [r.run_id for r in plan.pending] == list(failed)


def test_command_line_on_a_finished_sweep(pool_sweep, capsys):
    path, results, _ = pool_sweep
    assert main(["sweep", str(path), "--results", str(results), "--quiet"]) == 1  # a run failed
    out = capsys.readouterr().out
    assert "4 runs: 3 ok, 1 failed, 0 pending; 0 run now, 4 finished before" in out
    assert f"table: {(results / 'pool/sweep.md').resolve()}" in out
    code = main(["sweep", str(path), "--results", str(results), "--workers", "2",
                 "--scheduler", "tcp://127.0.0.1:1"])  # fmt: skip
    assert code == 2
    assert "error: --workers and --scheduler" in capsys.readouterr().err


# ---- the execution machinery with a cheap work function -----------------------------------------


def echo(config_path: Path, results: Path, force: bool):
    """Work function: no identification, just the window it was given."""
    config = load_experiment(config_path)
    return results, {"window": config.denoise.smoother.window_s}


def die_on_the_smallest_window(config_path: Path, results: Path, force: bool):
    if load_experiment(config_path).denoise.smoother.window_s == min(WINDOWS):
        os._exit(1)  # the worker process crashes (out of memory, segfault)
    return echo(config_path, results, force)


WINDOWS = [0.005, 0.01, 0.015, 0.02, 0.03, 0.04]


@pytest.fixture
def windows(sweep_file, tmp_path):
    path = sweep_file("windows", grid={"denoise.smoother.window_s": WINDOWS})
    return plan_sweep(load_sweep(path), tmp_path)


def test_an_interrupted_sweep_keeps_finished_runs_resumes_and_force_repeats(windows, pool):
    seen = []

    def interrupt(record):
        seen.append(record.run_id)
        raise KeyboardInterrupt  # Ctrl-C after the first run

    with pytest.raises(KeyboardInterrupt):
        execute(windows, echo, workers=1, progress=interrupt)
    finished = {p.stem for p in (windows.folder / "done").iterdir()}
    assert finished == set(seen)  # one run per worker in flight: nothing else had started
    table = pd.read_csv(windows.folder / "sweep.csv")  # written on the way out
    assert (table["status"] == "pending").sum() == len(WINDOWS) - len(seen)
    resumed = plan_sweep(windows.sweep, windows.folder.parent)
    assert set(resumed.done) == finished
    outcome = execute(resumed, echo, executor=pool)
    assert outcome.ran == len(WINDOWS) - len(finished) and outcome.count("ok") == len(WINDOWS)
    assert list(outcome.frame["window"]) == WINDOWS
    stamps = {p.name: p.stat().st_mtime_ns for p in (windows.folder / "done").iterdir()}
    forced = execute(
        plan_sweep(windows.sweep, windows.folder.parent, force=True), echo, executor=pool
    )
    assert (forced.ran, forced.skipped) == (len(WINDOWS), 0)
    assert all(p.stat().st_mtime_ns > stamps[p.name] for p in (windows.folder / "done").iterdir())


def test_a_crashed_worker_fails_its_run_and_the_others_go_on(windows):
    outcome = execute(windows, die_on_the_smallest_window, workers=1)
    assert outcome.frame["status"][0].startswith("failed: the worker was lost")
    assert outcome.count("ok") == len(WINDOWS) - 1  # on a new pool
    done = {p.stem for p in (windows.folder / "done").iterdir()}
    assert outcome.frame["run id"][0] not in done  # not finished: it runs again next time


def _children() -> set[int]:
    """Our child processes, but multiprocessing's resource tracker (it lives as long as we do)."""
    import psutil  # a dependency of distributed

    kids = psutil.Process().children(recursive=True)
    return {p.pid for p in kids if "resource_tracker" not in " ".join(p.cmdline())}


def test_kind_dask_without_an_address_starts_and_closes_its_own_cluster(sweep_file, tmp_path):
    path = sweep_file("own-cluster", grid={"seed": [1, 2]}, executor={"kind": "dask", "workers": 1})
    before = _children()
    outcome = execute(plan_sweep(load_sweep(path), tmp_path), echo)
    assert outcome.count("ok") == 2
    assert "local Dask cluster, 1 worker" in outcome.markdown.read_text()
    assert not _children() - before  # scheduler and worker processes are gone


def test_an_unreachable_scheduler_is_a_one_line_error(windows, monkeypatch):
    from hmid.errors import HmidError
    from hmid.sweep import _execute

    monkeypatch.setattr(_execute, "CONNECT_TIMEOUT_S", 1)
    with pytest.raises(HmidError, match=r"^cannot reach the Dask scheduler at tcp://127.0.0.1:9: "):
        execute(windows, echo, scheduler="tcp://127.0.0.1:9")
    table = pd.read_csv(windows.folder / "sweep.csv")
    assert (table["status"] == "pending").all()
