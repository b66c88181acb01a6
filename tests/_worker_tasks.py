"""Tasks for the worker tests: module-level, so that a spawned worker can import them."""

import os
from pathlib import Path


def write_pid(path: Path) -> None:
    """Say which process ran this task."""
    Path(path).write_text(str(os.getpid()), encoding="utf-8")


def die_in_a_worker(path: Path) -> None:
    """In a worker: the process ends at once, as a kill would end it. In the caller (the
    figure drawn again there): say so."""
    import multiprocessing

    if multiprocessing.parent_process() is not None:
        os._exit(1)
    write_pid(path)


def square(value: float) -> float:
    """A task with a result."""
    return value * value


def pid_after(seconds: float) -> int:
    """Which process ran this task, after ``seconds``."""
    import time

    time.sleep(seconds)
    return os.getpid()


def warn(text: str) -> int:
    """A task that warns."""
    import warnings

    warnings.warn(text, UserWarning, stacklevel=1)
    return os.getpid()


def write_pid_then_sleep(path: Path, seconds: float) -> None:
    """Say which process runs this task, then keep it busy."""
    import time

    write_pid(path)
    time.sleep(seconds)
