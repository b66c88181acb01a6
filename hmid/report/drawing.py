"""Figures drawn beside the work that does not need them: matplotlib takes about half a second
a figure and a report has a dozen, on a machine whose second core is idle while the rest of a
run goes on.

Workers are *spawned* (a fresh interpreter), never forked: the main process holds JAX's and
BLAS's threads, and a fork of a threaded process may deadlock. A spawned worker imports what it
draws with (seconds, for modules that read a fitted result): :meth:`Drawing.start` starts it
early, and one pool serves every run of a process. Figures are drawn exactly as inline: the same
function, the same arguments, the same file.
"""

from __future__ import annotations

import atexit
import os
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from hmid.errors import ConfigError

#: ``HMID_DRAW_WORKERS``: worker processes for figures (0: draw in the calling process)
WORKERS_VARIABLE = "HMID_DRAW_WORKERS"

_POOL: dict[tuple, ProcessPoolExecutor] = {}
_ALLOWED = [False]  # set by hmid's command line (allow_workers)


def allow_workers() -> None:
    """Let :func:`default_workers` choose a worker. A spawned worker imports the program's main
    module first, so its top level must be guarded by ``if __name__ == "__main__":`` (hmid's
    command line is; a user's script calling the pipeline need not be, and draws inline unless
    it sets ``HMID_DRAW_WORKERS``)."""
    _ALLOWED[0] = True


def default_workers() -> int:
    """The environment's choice; else none unless :func:`allow_workers` was called; else one
    worker where there is a second core (none on one core: it would only compete with the run;
    more than one costs each its imports), and none in a worker process (a sweep's, a blind
    suite's: its siblings use the other cores)."""
    import multiprocessing

    said = os.environ.get(WORKERS_VARIABLE)
    if said is not None:
        try:
            workers = int(said)
        except ValueError:
            workers = -1
        if workers < 0:
            raise ConfigError(f"{WORKERS_VARIABLE}={said!r}: give a whole number >= 0")
        return workers
    if not _ALLOWED[0] or multiprocessing.parent_process() is not None:
        return 0
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return 1 if (cores or 1) > 1 else 0


def _warm(modules: tuple[str, ...]) -> None:
    import importlib

    for name in ("matplotlib.figure", *modules):
        importlib.import_module(name)


def _ready() -> None:
    """A task that makes the pool spawn a worker (it spawns them as tasks come)."""


def _pool(workers: int, modules: tuple[str, ...]) -> ProcessPoolExecutor:
    pool = _POOL.get((workers, modules))
    if pool is None:
        from multiprocessing import get_context

        pool = _POOL[workers, modules] = ProcessPoolExecutor(
            workers, mp_context=get_context("spawn"), initializer=_warm, initargs=(modules,)
        )
        if len(_POOL) == 1:
            atexit.register(shutdown)
    return pool


def shutdown() -> None:
    """Stop the workers (at exit, or to free their memory)."""
    while _POOL:
        _POOL.popitem()[1].shutdown(wait=True, cancel_futures=True)


class Drawing:
    """Submit figure functions (module-level, picklable arguments); :meth:`wait` returns when
    all are drawn and raises the first failure. With no workers each is drawn at once.
    ``modules``: what the workers import when they start."""

    def __init__(self, workers: int | None = None, modules: tuple[str, ...] = ()) -> None:
        self.workers = default_workers() if workers is None else workers
        self.modules = tuple(modules)
        self._queued: list[tuple[Future, Callable[..., Any], tuple, dict]] = []

    def start(self) -> Drawing:
        """Start the workers now: they import while the caller works."""
        if self.workers:
            pool = _pool(self.workers, self.modules)
            try:
                for _ in range(self.workers):
                    pool.submit(_ready)
            except BrokenProcessPool:
                self._broken()
        return self

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> None:
        if self.workers:
            try:
                future = _pool(self.workers, self.modules).submit(fn, *args, **kwargs)
            except BrokenProcessPool:
                self._broken()
            else:
                self._queued.append((future, fn, args, kwargs))
                return
        fn(*args, **kwargs)

    def wait(self) -> None:
        """The caller, done with its own work, draws what no worker has begun (from the last
        submitted back), then waits for the rest; a figure whose worker died is drawn here."""
        queued, self._queued = self._queued, []
        for future, fn, args, kwargs in reversed(queued):
            if future.cancel():
                fn(*args, **kwargs)
        for future, fn, args, kwargs in queued:
            if future.cancelled():
                continue
            try:
                future.result()
            except BrokenProcessPool:
                self._broken()
                fn(*args, **kwargs)

    def _broken(self) -> None:
        """A worker died (killed, out of memory): this drawing draws inline from now on, and
        the next one starts a fresh pool."""
        pool = _POOL.pop((self.workers, self.modules), None)
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)
        self.workers = 0
