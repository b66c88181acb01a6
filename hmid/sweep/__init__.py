"""Sweeps: one experiment config run over many logs or many settings, compared in one table.

A sweep config (YAML) names a base experiment and the overrides of each run, as an explicit list
or a grid of dotted keys::

    name: windows
    base: ../demo.yaml
    grid:
      denoise.smoother.window_s: [0.005, 0.011, 0.021]
    executor: {kind: process, workers: 2}   # or {kind: dask, address: tcp://host:8786}

:func:`plan_sweep` resolves every run (its experiment config and a run id that hashes the config
and its input files) and finds runs that finished before; :func:`execute` runs the rest through a
``concurrent.futures.Executor`` (a local process pool or a Dask cluster) and writes
``results/<sweep>/``: ``runs/<run id>/`` (each run's config and results), ``done/<run id>.json``
(each finished run's record: its summary or its one-line error) and ``sweep.csv`` + ``sweep.md``
(one row per run). What a run does is the ``work`` function passed in (for the identification
study: :func:`pipelines.sweep.identify`).
"""

from hmid.sweep._config import ExecutorSection, SweepConfig, apply_overrides, load_sweep
from hmid.sweep._execute import SweepOutcome, execute, open_executor
from hmid.sweep._plan import PlannedRun, SweepPlan, plan_sweep
from hmid.sweep._records import RunRecord, RunTask, Work, read_done, run_task
from hmid.sweep._table import sweep_frame, write_table

__all__ = [
    "ExecutorSection",
    "PlannedRun",
    "RunRecord",
    "RunTask",
    "SweepConfig",
    "SweepOutcome",
    "SweepPlan",
    "Work",
    "apply_overrides",
    "execute",
    "load_sweep",
    "open_executor",
    "plan_sweep",
    "read_done",
    "run_task",
    "sweep_frame",
    "write_table",
]
