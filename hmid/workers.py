"""Work done beside the run on a second core: model families, loop screens, report figures.

Workers are *spawned* (a fresh interpreter), never forked: the main process holds JAX's and
BLAS's threads, and a fork of a threaded process may deadlock. A spawned worker imports what its
tasks need (seconds, for modules that read a fitted result): :meth:`Tasks.start` has it import
them early, and one pool serves every run of a process. A task gives what it gives inline: the
same function on the same arguments. The caller, once done with its own part, takes back every
task no worker has begun (:meth:`Tasks.results`), so work is shared however long each task is.
"""

from __future__ import annotations

import atexit
import importlib
import multiprocessing
import os
import signal
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing import active_children, get_context
from typing import Any

from tqdm import tqdm

from hmid.errors import ConfigError

#: ``HMID_WORKERS``: worker processes beside the run (0: everything in the calling process)
WORKERS_VARIABLE = "HMID_WORKERS"

_POOL: dict[int, _Pool] = {}
_ALLOWED = [False]  # set by hmid's command line (allow_workers)


def allow_workers() -> None:
    """Let :func:`default_workers` choose a worker. A spawned worker imports the program's main
    module first, so its top level must be guarded by ``if __name__ == "__main__":`` (hmid's
    command line is; a user's script calling the pipeline need not be, and works in its own
    process unless it sets ``HMID_WORKERS``)."""
    _ALLOWED[0] = True


def default_workers() -> int:
    """None in a worker process (this pool's, a sweep's, a blind suite's: its siblings use the
    other cores, and a worker's own tasks run where it is); else the environment's choice; else
    none unless :func:`allow_workers` was called; else one worker where there is a second core
    (none on one core: it would only compete with the run; more than one costs each its
    imports)."""
    if multiprocessing.parent_process() is not None:
        return 0
    said = os.environ.get(WORKERS_VARIABLE)
    if said is not None:
        try:
            workers = int(said)
        except ValueError:
            workers = -1
        if workers < 0:
            raise ConfigError(f"{WORKERS_VARIABLE}={said!r}: give a whole number >= 0")
        return workers
    if not _ALLOWED[0]:
        return 0
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return 1 if (cores or 1) > 1 else 0


def _warm(modules: tuple[str, ...]) -> None:
    """A task that makes the pool spawn a worker (it spawns them as tasks come) and has it
    import ``modules``; ``"module:function"`` also calls the function (e.g. to build a
    registry that the first task would otherwise wait for)."""
    for entry in modules:
        name, _, function = entry.partition(":")
        module = importlib.import_module(name)
        if function:
            getattr(module, function)()


class _Pool:
    """A process pool and the worker processes it started (multiprocessing's children that
    appeared while it was handed a task: the pool spawns them as tasks come), so that they can
    be stopped without waiting for their tasks."""

    def __init__(self, workers: int) -> None:

        self.executor = ProcessPoolExecutor(
            workers, mp_context=get_context("spawn"), initializer=_worker_start
        )
        self.processes: set = set()
        self.outstanding: set[Future] = set()  # handed out by any Tasks, not yet done

    def submit(self, fn: Callable[..., Any], /, *args: Any) -> Future:

        before = set(active_children())
        with _interrupts_blocked():
            future = self.executor.submit(fn, *args)
        self.processes.update(set(active_children()) - before)
        return future

    def hand(self, fn: Callable[..., Any], /, *args: Any) -> Future:
        """A task submitted for a :class:`Tasks` (a warm-up's imports are not one)."""
        future = self.submit(fn, *args)
        self.outstanding.add(future)
        future.add_done_callback(self.outstanding.discard)
        return future

    def busy(self) -> int:
        """Tasks handed to the workers and not yet done, whichever :class:`Tasks` handed
        them out."""
        return sum(1 for future in list(self.outstanding) if not future.done())

    def stop(self) -> None:
        """Kill the workers and reap them, then wait for the pool's own thread: it sees them
        die, marks their futures broken and closes its queues and its wake-up pipe. Left
        running, it may close that pipe while the interpreter's exit hook
        (concurrent.futures' ``_python_exit``, unlocked in Python 3.11) writes to it, which
        prints an ``OSError: Bad file descriptor`` traceback after the program's last line."""
        for process in self.processes:
            process.kill()
        for process in self.processes:
            # a killed process is gone at once, but on a loaded machine its reaping can lag a
            # second (it then stays listed as an active child)
            process.join(timeout=5.0)
        # futures left uncancelled: the pool's thread marks them broken when it sees the dead
        # workers, and Python 3.11's raises if they were cancelled
        self.executor.shutdown(wait=True)


@contextmanager
def _interrupts_blocked() -> Iterator[None]:
    """SIGINT held back from this thread: a worker started meanwhile inherits it blocked, so
    that a Ctrl-C while it imports (before :func:`_worker_start`) is not its to report; this
    process gets it once the block ends. (Where there is no signal mask: nothing.)"""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


def _worker_start() -> None:
    """A worker's start. Ctrl-C, which the terminal sends to every process of the command, is
    the caller's to handle (it stops the workers), not a worker's to report with a traceback.
    Progress bars (tqdm's, e.g. the sampler's, shown nowhere in a worker) get a lock of this
    process: tqdm's default, a multiprocessing lock, stays registered with multiprocessing's
    resource tracker when the worker is killed, and the tracker then warns of a leaked
    semaphore as the program ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    tqdm.set_lock(threading.RLock())


def _pool(workers: int) -> _Pool:
    pool = _POOL.get(workers)
    if pool is None:
        pool = _POOL[workers] = _Pool(workers)
        if len(_POOL) == 1:
            atexit.register(shutdown)
    return pool


def shutdown() -> None:
    """Stop the workers (when a program is done with them, interrupted, or to free their
    memory). They are killed rather than asked to finish: no result is awaited from them, a
    task may have minutes left (a family's fit), and an interpreter that has loaded JAX and
    matplotlib takes most of a second to tear itself down. (At exit it comes too late for
    that: the interpreter first joins the pool's thread, which waits for the workers to
    finish.)"""
    while _POOL:
        _POOL.popitem()[1].stop()


@dataclass
class _Task:
    fn: Callable[..., Any]
    args: tuple
    here: Callable[[], Any]  # what the caller runs if it takes the task itself
    future: Future | None = None  # None while held back from the workers
    there: bool = False  # its future is a worker's (a _Done)
    seconds: float = 0.0  # how long it ran, wherever it ran (known once it is done)

    def run_here(self) -> Future:
        """Run the task in the caller, now."""
        start = time.perf_counter()
        future = _finished(self.here())
        self.seconds, self.there = time.perf_counter() - start, False
        return future


@dataclass(frozen=True)
class _Warning:
    message: str
    category: type
    filename: str
    lineno: int


@dataclass(frozen=True)
class _Done:
    value: Any
    warnings: tuple[_Warning, ...]
    seconds: float


def _call(fn: Callable[..., Any], args: tuple) -> _Done:
    """In a worker: ``fn(*args)`` and the warnings it gave, which the caller says."""
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        value = fn(*args)
    said = (_Warning(str(w.message), w.category, w.filename, w.lineno) for w in caught)
    return _Done(value, tuple(said), time.perf_counter() - start)


def _value(task: _Task) -> Any:
    assert task.future is not None  # results() has run or handed out every task
    found = task.future.result()
    if not task.there:
        return found
    for w in found.warnings:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    task.seconds = found.seconds
    return found.value


class Tasks:
    """Submit module-level functions with picklable arguments; :meth:`results` gives their
    results in order once all are done and raises the first failure (a worker's warnings are
    said in the caller). With no workers each runs at once, in the caller.

    ``ahead``: how many tasks each worker is handed beyond the one it runs (None: all at once,
    so that workers go on while the caller does other things). With a limit, the rest are held
    back, and the caller, when it asks for the results, takes them in the order submitted while
    the workers are kept fed: submitted dearest first, that shares them out as evenly as the
    longest allows.
    """

    def __init__(self, workers: int | None = None, ahead: int | None = None) -> None:
        self.workers = default_workers() if workers is None else workers
        self.ahead = ahead
        self._tasks: list[_Task] = []
        #: the seconds the tasks collected so far ran, in a worker or here: work done beside a
        #: caller that waited for none of it still took its time
        self.seconds = 0.0

    def start(self, modules: tuple[str, ...] = ()) -> Tasks:
        """Start the workers now, importing ``modules``, while the caller works."""
        if self.workers:
            try:
                for _ in range(self.workers):
                    _pool(self.workers).submit(_warm, tuple(modules))
            except BrokenProcessPool:
                self._broken()
        return self

    def submit(
        self, fn: Callable[..., Any], /, *args: Any, here: Callable[[], Any] | None = None
    ) -> None:
        """Queue ``fn(*args)``; ``here`` is what the caller runs instead if it runs the task
        itself (default the same call), e.g. the same work on objects it already holds."""
        task = _Task(fn, args, (lambda: fn(*args)) if here is None else here)
        self._tasks.append(task)
        if self.workers:
            self._hand_out(self._tasks)
        else:
            task.future = task.run_here()

    def cancel(self) -> None:
        """Drop every task not collected: those no worker has begun are cancelled, those
        running end in their worker and their results are let go (a run that failed after
        handing work out leaves the shared pool free for what comes next)."""
        tasks, self._tasks = self._tasks, []
        for task in tasks:
            if task.future is not None:
                task.future.cancel()

    @property
    def queued(self) -> int:
        """Tasks submitted whose results are not yet collected."""
        return len(self._tasks)

    def results(self, step: Callable[[], Any] | None = None) -> list[Any]:
        """Every task's result, in the order submitted. The caller runs the tasks held back
        (first to last, handing out more as workers free up), then what no worker has begun
        (from the last submitted back), then waits for the rest; a task whose worker died is
        run here. The queue is empty afterwards. ``step()`` is called as each result is in."""
        tasks, self._tasks = self._tasks, []
        while True:
            self._hand_out(tasks)
            held = next((task for task in tasks if task.future is None), None)
            if held is None:
                break
            held.future = held.run_here()
        for task in reversed(tasks):
            assert task.future is not None  # the loop above ran every task held back
            if task.future.cancel():
                task.future = task.run_here()
        out = []
        for task in tasks:
            try:
                out.append(_value(task))
            except BrokenProcessPool:
                self._broken()
                task.future = task.run_here()
                out.append(task.future.result())
            self.seconds += task.seconds
            if step is not None:
                step()
        return out

    def _hand_out(self, tasks: list[_Task]) -> None:
        """Submit held-back tasks while the workers have room for them. With a limit, there
        is none while work another caller handed out is not done (a run's free runs, handed
        out all at once): a task put behind it could neither be taken back nor begun, and
        would keep this caller waiting where it could have run the task itself."""
        limit = None if self.ahead is None else self.workers * (1 + self.ahead)
        for task in tasks:
            if not self.workers:
                return
            if task.future is not None:
                continue
            busy = sum(1 for t in tasks if t.future is not None and not t.future.done())
            if limit is not None and (busy >= limit or _pool(self.workers).busy() > busy):
                return
            try:
                task.future = _pool(self.workers).hand(_call, task.fn, task.args)
            except BrokenProcessPool:
                self._broken()
            else:
                task.there = True

    def _broken(self) -> None:
        """A worker died (killed, out of memory): these tasks run inline from now on, and the
        next :class:`Tasks` starts a fresh pool."""
        pool = _POOL.pop(self.workers, None)
        if pool is not None:
            pool.executor.shutdown(wait=False, cancel_futures=True)
        self.workers = 0


def beside(fn: Callable[..., Any], /, *args: Any) -> Callable[[], Any]:
    """``fn(*args)`` handed to a free worker while the caller goes on (a family fit's side work,
    :attr:`hmid.families.FitContext.beside`); the callable returned gives its result, running
    it in the caller if no worker has begun it."""
    tasks = Tasks()
    tasks.submit(fn, *args)
    return lambda: tasks.results()[0]


def draw(tasks: Tasks | None, fn: Callable[..., Any], /, *args: Any) -> None:
    """``fn(*args)`` queued with ``tasks`` (a report's figures, drawn beside its tables; taken
    back with their results), or now where there are none."""
    if tasks is None:
        fn(*args)
    else:
        tasks.submit(fn, *args)


def _finished(value: Any) -> Future:
    future: Future = Future()
    future.set_result(value)
    return future
