"""Executing a planned sweep through any ``concurrent.futures.Executor``.

The runs go to a local process pool by default, or to a Dask cluster (a
``distributed.Client``'s executor) when the sweep or the caller names a scheduler: the same code
path either way. Workers import hmid themselves (the pool starts fresh processes, never forks a
parent that may hold JAX threads) and save each run's record before returning it, so an
interrupted sweep keeps every finished run. A local pool holds one run per worker at a time and
its workers ignore Ctrl-C: on an interruption the running runs finish and record themselves,
nothing else starts. A worker that dies fails its run; the pool is replaced and the sweep goes
on. The table is rewritten at the end, also after an interruption or an error, with unfinished
runs shown as pending.

Dask workers for sweeps should run one thread each (``dask worker --nthreads 1``): runs are
CPU-bound Python and capture their warnings per process. The results folder must be on a file
system that the workers share with the caller.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import (
    FIRST_COMPLETED,
    BrokenExecutor,
    Executor,
    Future,
    ProcessPoolExecutor,
    wait,
)
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from threadpoolctl import threadpool_limits

from hmid.errors import ConfigError, HmidError, HmidWarning
from hmid.sweep._config import ExecutorSection
from hmid.sweep._plan import PlannedRun, SweepPlan
from hmid.sweep._records import RunRecord, Work, lost_record, read_done, run_task
from hmid.sweep._table import sweep_frame, write_table

#: How long to wait for a Dask scheduler before giving up.
CONNECT_TIMEOUT_S = 20


_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _start_worker(threads: int) -> None:
    """Pool worker start-up: leave Ctrl-C to the parent, share the cores between thread pools.

    Ctrl-C in a terminal reaches the whole process group: a worker interrupted inside the pool's
    queue can deadlock the pool. The parent instead stops submitting and lets the running runs
    finish (and record themselves). Without the thread limits each worker's BLAS starts a thread
    per core, and their idle-spinning threads slow the other workers down (Dask's nanny sets the
    same variables to 1); limits the user set in the environment are kept.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if any(name in os.environ for name in _THREAD_VARIABLES):
        return
    for name in _THREAD_VARIABLES:  # read by libraries loaded later (SciPy's own OpenBLAS)
        os.environ[name] = str(threads)

    threadpool_limits(limits=threads)  # libraries loaded already (NumPy's OpenBLAS), for good


#: A worker process is replaced after this many runs: each run leaves some tens of MB behind in
#: it (JAX's caches of the programs it compiled, which outlive the run), and the full blind
#: suite's two workers grew to 11 GB after about 150 cases each and were killed for memory; a
#: fresh worker costs a few seconds of imports, against runs of tens of seconds.
RUNS_PER_WORKER = 16


@contextmanager
def open_executor(section: ExecutorSection) -> Iterator[Executor]:
    """An executor for ``section``, shut down (cluster and client closed) on leaving."""
    cores = os.cpu_count() or 1
    workers = section.workers or cores
    if section.kind == "process":
        context = multiprocessing.get_context("spawn")  # fresh interpreters: no forked threads
        threads = max(1, cores // workers)
        with ProcessPoolExecutor(
            workers, mp_context=context, initializer=_start_worker, initargs=(threads,),
            max_tasks_per_child=RUNS_PER_WORKER,
        ) as pool:  # fmt: skip
            yield pool
        return
    from distributed import Client, LocalCluster

    with ExitStack() as stack:
        if section.address is None:
            cluster = LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0"
            )
            stack.callback(cluster.close)
            client = Client(cluster)
        else:
            try:
                client = Client(section.address, timeout=CONNECT_TIMEOUT_S)
            except OSError as err:  # includes timeouts
                raise HmidError(
                    f"cannot reach the Dask scheduler at {section.address}: {err}"
                ) from None
        stack.callback(client.close)
        threaded = {n for n in client.nthreads().values() if n > 1}
        if threaded:
            warnings.warn(
                f"the Dask workers at {section.address} run {max(threaded)} threads each; "
                "sweep runs are CPU-bound Python and capture warnings per process: start the "
                "workers with one thread each (dask worker --nthreads 1)",
                HmidWarning,
                stacklevel=3,
            )
        yield client.get_executor(pure=False)  # a concurrent.futures.Executor


def _describe(section: ExecutorSection, executor: Executor | None) -> str:
    if executor is not None:
        return f"the caller's {type(executor).__name__}"
    if section.address is not None:
        return f"Dask cluster at {section.address}"
    workers = section.workers or os.cpu_count() or 1
    where = "local process pool" if section.kind == "process" else "local Dask cluster"
    return f"{where}, {workers} worker{'s' if workers > 1 else ''}"


@dataclass(frozen=True)
class SweepOutcome:
    """What a sweep left behind: the table (CSV and Markdown) and how many runs ended how."""

    folder: Path
    table: Path  # sweep.csv
    markdown: Path  # sweep.md
    frame: pd.DataFrame
    ran: int  # executed now
    skipped: int  # finished before, not executed again

    def count(self, status: str) -> int:
        """Rows whose status is ``status`` (``ok``, ``failed`` or ``pending``)."""
        return int(self.frame["status"].str.split(":").str[0].eq(status).sum())

    def describe(self) -> str:
        return (
            f"{len(self.frame)} runs: {self.count('ok')} ok, {self.count('failed')} failed, "
            f"{self.count('pending')} pending; {self.ran} run now, {self.skipped} finished before"
        )


def _run_all(
    pool: Executor,
    replace: Callable[[], Executor | None],
    window: int,
    plan: SweepPlan,
    work: Work,
    pending: tuple[PlannedRun, ...],
    records: dict[str, RunRecord],
    progress: Callable[[RunRecord], None] | None,
) -> None:
    """Submit ``pending`` runs keeping at most ``window`` in flight; collect their records.

    A pool broken by a dying worker (out of memory, a crash) fails the runs it held and is
    replaced (when ``replace`` gives a new one), so that the other runs go on.
    """
    queue = iter(pending)
    futures: dict[Future, PlannedRun] = {}

    def fill() -> None:
        nonlocal pool
        while len(futures) < window and (run := next(queue, None)) is not None:
            task = plan.task(run)
            try:
                futures[pool.submit(run_task, work, task)] = run
            except BrokenExecutor:
                fresh = replace()
                if fresh is None:
                    raise
                pool = fresh
                futures[pool.submit(run_task, work, task)] = run

    try:
        fill()
        while futures:
            finished, _ = wait(futures, return_when=FIRST_COMPLETED)
            for future in sorted(finished, key=lambda f: futures[f].number):
                task = plan.task(futures.pop(future))
                try:
                    record = future.result()
                except Exception as err:  # the worker died or the cluster lost it
                    record = lost_record(task, err)
                records[task.run_id] = record
                if progress is not None:
                    progress(record)
            fill()
    finally:
        for future in futures:
            future.cancel()  # runs not yet started, when leaving early


def execute(
    plan: SweepPlan,
    work: Work,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    limit: int | None = None,
    progress: Callable[[RunRecord], None] | None = None,
) -> SweepOutcome:
    """Run the pending runs of ``plan`` with ``work`` and write the sweep's table.

    ``workers`` and ``scheduler`` override the sweep's executor settings; an ``executor`` given
    here is used as it is and left open. ``limit`` runs at most that many pending runs (the rest
    stay pending for the next call). ``progress`` is called with each run's record as it ends.
    ``work`` must be a top-level function: it is sent to other processes by reference.
    """
    if limit is not None and limit < 0:
        raise ConfigError(f"limit must be 0 or more, got {limit}")
    pending = plan.pending[:limit] if limit is not None else plan.pending
    section = plan.sweep.executor.with_options(workers=workers, scheduler=scheduler)
    records: dict[str, RunRecord] = dict(plan.done)
    try:
        if pending:
            with ExitStack() as stack:

                def new_pool() -> Executor | None:  # a caller's executor is not replaced
                    return None if executor else stack.enter_context(open_executor(section))

                # a local pool gets one run per worker at a time: on Ctrl-C only the running
                # runs finish (a cluster's scheduler cancels queued runs itself)
                own_pool = executor is None and section.kind == "process"
                window = (section.workers or os.cpu_count() or 1) if own_pool else len(pending)
                pool = executor or new_pool()
                assert pool is not None  # new_pool() opens one where the caller gave none
                _run_all(pool, new_pool, window, plan, work, pending, records, progress)
    finally:
        for run in pending:  # runs that recorded themselves while we were interrupted
            run_id = run.run_id
            assert run_id is not None  # pending runs are the valid ones
            if run_id not in records and (record := read_done(plan.folder, run_id)):
                records[run_id] = record
        table, markdown = write_table(plan, records, _describe(section, executor))
    return SweepOutcome(
        plan.folder, table, markdown, sweep_frame(plan, records), len(pending), len(plan.done)
    )
