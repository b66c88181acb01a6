"""Tasks for the drawing tests: module-level, so that a spawned worker can import them."""

import os
import time
from pathlib import Path


def sleep(seconds: float) -> None:
    time.sleep(seconds)


def write_pid(path: Path) -> None:
    """Say which process ran this task."""
    Path(path).write_text(str(os.getpid()), encoding="utf-8")
