"""Figures drawn by a worker process: the same files as inline, failures raised, and the
caller drawing what the worker has not begun."""

import os
import time

import _drawing_tasks
import pandas as pd
import pytest
from _drawing_tasks import write_pid

from hmid.plots import plot_scores
from hmid.report import drawing as drawing_module
from hmid.report.drawing import WORKERS_VARIABLE, Drawing, default_workers

SCORES = pd.DataFrame(
    {"model": ["a", "b"], "rmse (held-out)": [0.1, 0.2], "nrmse_fit_pct (held-out)": [90.0, 80.0]}
)


def test_a_worker_draws_the_same_file_as_inline(tmp_path):
    inline, drawn = tmp_path / "inline.png", tmp_path / "drawn.png"
    Drawing(workers=0).submit(plot_scores, SCORES, inline)
    assert inline.exists()  # drawn at once
    drawing = Drawing(workers=1).start()
    drawing.submit(plot_scores, SCORES, drawn)
    drawing.wait()
    assert drawn.read_bytes() == inline.read_bytes()


def test_a_failing_figure_fails_the_wait(tmp_path):
    drawing = Drawing(workers=1)
    drawing.submit(plot_scores, SCORES.drop(columns="rmse (held-out)"), tmp_path / "x.png")
    with pytest.raises(KeyError, match="rmse"):
        drawing.wait()


def test_the_caller_draws_what_the_worker_has_not_begun(tmp_path):
    drawing = Drawing(workers=1).start()
    drawing.submit(time.sleep, 1.0)  # the worker is busy while the caller reaches wait()
    paths = [tmp_path / f"{k}.pid" for k in range(5)]
    for path in paths:
        drawing.submit(write_pid, path)
    drawing.wait()
    pids = [int(p.read_text()) for p in paths]  # every task ran, once
    assert pids[-1] == os.getpid()  # the last submitted: stolen first


def test_the_number_of_workers_is_read_from_the_environment(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "0")
    assert default_workers() == 0
    monkeypatch.setenv(WORKERS_VARIABLE, "two")
    with pytest.raises(ValueError, match=f"{WORKERS_VARIABLE}='two': give a whole number"):
        default_workers()


def test_a_worker_process_draws_its_own_figures(monkeypatch):
    """In a sweep's worker the siblings use the other cores (and a daemonic worker may not
    start processes at all)."""
    import multiprocessing

    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    monkeypatch.setattr(drawing_module, "_ALLOWED", [True])
    monkeypatch.setattr(drawing_module.os, "sched_getaffinity", lambda _: {0, 1}, raising=False)
    assert default_workers() == 1
    monkeypatch.setattr(multiprocessing, "parent_process", lambda: object())
    assert default_workers() == 0


def test_a_caller_whose_main_module_may_be_unguarded_draws_inline(monkeypatch):
    """A spawned worker imports the program's main module: only hmid's command line, whose main
    is guarded, lets workers be chosen without the environment saying so."""
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    monkeypatch.setattr(drawing_module, "_ALLOWED", [False])
    assert default_workers() == 0
    monkeypatch.setenv(WORKERS_VARIABLE, "1")
    assert default_workers() == 1


def test_a_dead_worker_s_figures_are_drawn_here(tmp_path):
    """A worker killed (out of memory, a signal) loses no figure: the caller draws the one it
    was drawing and every later one."""
    drawing = Drawing(workers=1).start()
    killed, later = tmp_path / "killed.pid", tmp_path / "later.pid"
    drawing.submit(_drawing_tasks.die_in_a_worker, killed)
    (dying, *_), deadline = drawing._queued[0], time.monotonic() + 60
    while not dying.done() and time.monotonic() < deadline:
        time.sleep(0.05)  # the worker begins it and dies
    drawing.submit(write_pid, later)
    drawing.wait()
    assert int(killed.read_text()) == int(later.read_text()) == os.getpid()
    assert drawing.workers == 0
