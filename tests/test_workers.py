"""Tasks done by a worker process: the same results as inline (a figure's file byte for byte),
failures raised, work shared, and the caller running what the worker has not begun."""

import os
import threading
import time

import _worker_tasks
import pandas as pd
import pytest
from _worker_tasks import pid_after, square, warn, write_pid, write_pid_then_sleep

from hmid import workers as workers_module
from hmid.plots import plot_scores
from hmid.workers import WORKERS_VARIABLE, Tasks, default_workers

SCORES = pd.DataFrame(
    {"model": ["a", "b"], "rmse (held-out)": [0.1, 0.2], "nrmse_fit_pct (held-out)": [90.0, 80.0]}
)


def test_a_worker_draws_the_same_file_as_inline(tmp_path):
    inline, drawn = tmp_path / "inline.png", tmp_path / "drawn.png"
    Tasks(workers=0).submit(plot_scores, SCORES, inline)
    assert inline.exists()  # drawn at once
    drawing = Tasks(workers=1).start()
    drawing.submit(plot_scores, SCORES, drawn)
    drawing.results()
    assert drawn.read_bytes() == inline.read_bytes()


def test_a_failing_figure_fails_the_wait(tmp_path):
    drawing = Tasks(workers=1)
    drawing.submit(plot_scores, SCORES.drop(columns="rmse (held-out)"), tmp_path / "x.png")
    with pytest.raises(KeyError, match="rmse"):
        drawing.results()


def test_the_caller_draws_what_the_worker_has_not_begun(tmp_path):
    drawing = Tasks(workers=1).start()
    drawing.submit(time.sleep, 1.0)  # the worker is busy while the caller asks for results
    paths = [tmp_path / f"{k}.pid" for k in range(5)]
    for path in paths:
        drawing.submit(write_pid, path)
    drawing.results()
    pids = [int(p.read_text()) for p in paths]  # every task ran, once
    assert pids[-1] == os.getpid()  # the last submitted: stolen first


def test_results_come_in_the_order_submitted_wherever_they_ran():
    tasks = Tasks(workers=1).start()
    for value in range(6):  # the caller takes its share slowly: the worker has time for one
        tasks.submit(square, value, here=lambda value=value: (time.sleep(0.2), ("here", value))[1])
    found = tasks.results()
    assert all(v in (k * k, ("here", k)) for k, v in enumerate(found))
    assert found[0] == 0  # handed to the worker at once: never taken back
    assert tasks.results() == []


def test_a_worker_s_warnings_are_said_by_the_caller():
    tasks = Tasks(workers=1).start()
    tasks.submit(warn, "said in the worker")
    tasks.submit(time.sleep, 0.5)  # the caller takes this one; the worker has the first
    with pytest.warns(UserWarning, match="said in the worker"):
        pid, _ = tasks.results()
    assert pid != os.getpid()


def test_with_a_limit_ahead_both_take_the_next_task_when_free():
    """Held back, the tasks go to whichever process is free: submitted dearest first, the
    worker and the caller each run one of the two long ones."""
    tasks = Tasks(workers=1, ahead=0).start()
    tasks.submit(time.sleep, 0.5)  # the worker's imports are done before the race begins
    tasks.results()
    for seconds in (1.0, 1.0, 0.05, 0.05):
        tasks.submit(pid_after, seconds)
    first, second, *_ = tasks.results()
    assert first != second and os.getpid() in (first, second)


def test_the_number_of_workers_is_read_from_the_environment(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "0")
    assert default_workers() == 0
    monkeypatch.setenv(WORKERS_VARIABLE, "two")
    with pytest.raises(ValueError, match=f"{WORKERS_VARIABLE}='two': give a whole number"):
        default_workers()


def test_a_worker_process_runs_its_own_tasks(monkeypatch):
    """In a sweep's worker the siblings use the other cores (and a daemonic worker may not
    start processes at all); in this pool's, a task's own tasks (the SLS family's sign check)
    run where it is, whatever the environment says."""
    import multiprocessing

    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    monkeypatch.setattr(workers_module, "_ALLOWED", [True])
    monkeypatch.setattr(workers_module.os, "sched_getaffinity", lambda _: {0, 1}, raising=False)
    assert default_workers() == 1
    monkeypatch.setattr(multiprocessing, "parent_process", lambda: object())
    assert default_workers() == 0
    monkeypatch.setenv(WORKERS_VARIABLE, "1")
    assert default_workers() == 0


def test_a_caller_whose_main_module_may_be_unguarded_draws_inline(monkeypatch):
    """A spawned worker imports the program's main module: only hmid's command line, whose main
    is guarded, lets workers be chosen without the environment saying so."""
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    monkeypatch.setattr(workers_module, "_ALLOWED", [False])
    assert default_workers() == 0
    monkeypatch.setenv(WORKERS_VARIABLE, "1")
    assert default_workers() == 1


def test_a_dead_worker_s_figures_are_drawn_here(tmp_path):
    """A worker killed (out of memory, a signal) loses no figure: the caller draws the one it
    was drawing and every later one."""
    drawing = Tasks(workers=1).start()
    killed, later = tmp_path / "killed.pid", tmp_path / "later.pid"
    drawing.submit(_worker_tasks.die_in_a_worker, killed)
    dying, deadline = drawing._tasks[0].future, time.monotonic() + 60
    while not dying.done() and time.monotonic() < deadline:
        time.sleep(0.05)  # the worker begins it and dies
    drawing.submit(write_pid, later)
    drawing.results()
    assert int(killed.read_text()) == int(later.read_text()) == os.getpid()
    assert drawing.workers == 0


def test_shutdown_stops_a_busy_worker_at_once(tmp_path):
    """The workers are stopped, not waited for: a task may have minutes left. (Judged by the
    busy worker's own pid: other tests' pools may still be starting or ending processes.)"""
    workers_module.shutdown()  # a pool left by an earlier test is not this test's
    tasks = Tasks(workers=1).start()
    pid_file = tmp_path / "busy.pid"
    tasks.submit(_worker_tasks.write_pid_then_sleep, pid_file, 60.0)
    deadline = time.monotonic() + 60
    while not pid_file.exists() and time.monotonic() < deadline:
        time.sleep(0.05)  # the worker has begun the task
    busy = int(pid_file.read_text())
    started = time.monotonic()
    workers_module.shutdown()
    assert time.monotonic() - started < 10.0
    with pytest.raises(ProcessLookupError):  # killed and reaped
        os.kill(busy, 0)


def test_shutdown_leaves_no_pool_thread_for_the_exit_hook(tmp_path):
    """After a shutdown the pool's own thread has ended: the interpreter's exit hook would
    otherwise race it for its wake-up pipe (a 'Bad file descriptor' traceback after a
    SIGTERM's one line)."""
    workers_module.shutdown()
    before = set(threading.enumerate())
    tasks = Tasks(workers=1).start()
    pid_file = tmp_path / "busy.pid"
    tasks.submit(_worker_tasks.write_pid_then_sleep, pid_file, 60.0)
    deadline = time.monotonic() + 60
    while not pid_file.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert set(threading.enumerate()) - before  # the pool's thread (and its queue's) ran
    workers_module.shutdown()
    assert not [t for t in set(threading.enumerate()) - before if t.is_alive()]


def test_cancel_drops_what_no_worker_has_begun(tmp_path):
    """A run that fails after handing work out: the task running ends in its worker, the ones
    queued behind it (beyond the one the pool has already passed to the worker's queue) never
    start, and nothing is left to collect."""
    tasks = Tasks(workers=1).start()
    tasks.submit(time.sleep, 0.5)
    paths = [tmp_path / f"{k}.pid" for k in range(4)]
    for path in paths:
        tasks.submit(write_pid, path)
    tasks.cancel()
    assert tasks.queued == 0 and tasks.results() == []
    after = Tasks(workers=1)  # the pool's next task waits for whatever the worker still runs
    after.submit(square, 3)
    assert after.results() == [9]
    assert sum(path.exists() for path in paths) <= 1  # at most the one already passed on


def test_a_full_pool_is_not_handed_more_by_a_caller_with_a_limit(tmp_path):
    """Work handed out all at once by one caller (a run's free runs) fills the worker's queue;
    a caller with a limit (the loop's screens) then runs its tasks itself rather than put them
    behind that work and wait for them. The seconds each task ran are summed wherever."""
    tasks = Tasks(workers=1).start()
    tasks.submit(square, 2)
    tasks.results()  # the worker is up
    busy = Tasks(workers=1)
    busy.submit(time.sleep, 1.5)
    screens = Tasks(workers=1, ahead=1)
    paths = [tmp_path / f"{k}.pid" for k in range(4)]
    start = time.perf_counter()
    for path in paths:  # the caller's own share takes a while: time for the pool to pass on
        screens.submit(write_pid_then_sleep, path, 0.1)  # what it was handed
    screens.results()
    assert time.perf_counter() - start < 1.0  # none waited behind the sleep
    assert [int(p.read_text()) for p in paths] == [os.getpid()] * 4
    busy.results()
    assert 1.4 < busy.seconds < 3.0 and 0.4 <= screens.seconds < 1.0
