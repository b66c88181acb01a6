"""What ``hmid run`` shows while it works: each stage with its elapsed time, and bars for the long
parts (the SLS posterior, the figures).

In a terminal (stderr a TTY) the stages and parts are tqdm bars; otherwise (a log file, CI) one
line per stage and nothing else, so logs stay short. Workers are separate processes: they learn
that bars are wanted from :data:`VARIABLE` in the environment, which the command sets before it
starts them.
"""

from __future__ import annotations

import os
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, TextIO

from tqdm import tqdm

#: Set to "1" by a command that shows bars; read by the parts that draw them (also in workers).
VARIABLE = "HMID_PROGRESS"


def bars_wanted() -> bool:
    """Whether a long part should draw its bar (the command runs in a terminal)."""
    return os.environ.get(VARIABLE) == "1"


@dataclass
class Progress:
    """Stage lines and bars for one command, on ``stream`` (default: stderr)."""

    label: str = "hmid run"
    stream: TextIO | None = None
    bars: bool | None = None  # None: when the stream is a terminal
    quiet: bool = False
    _start: float = field(default_factory=time.perf_counter)
    _bar: Any = None  # a tqdm bar in a terminal

    def __post_init__(self) -> None:
        self.stream = sys.stderr if self.stream is None else self.stream
        if self.bars is None:
            isatty = getattr(self.stream, "isatty", None)
            self.bars = bool(isatty and isatty()) and not self.quiet

    def stages(self, names: list[str]) -> Progress:
        """Begin the bar over ``names`` (a terminal only)."""
        if self.bars:
            self._bar = tqdm(total=len(names), desc=self.label, unit="stage", file=self.stream,
                             bar_format="{desc}: {n}/{total} stages |{bar:20}| {elapsed}{postfix}",
                             leave=False)  # fmt: skip
        return self

    def started(self, name: str) -> None:
        if self._bar is not None:
            self._bar.set_postfix_str(f"{name} …")

    def done(self, name: str, seconds: float, cached: bool | None) -> None:
        how = " (cached)" if cached else ""
        line = f"{self.label}: {name} {seconds:.1f} s{how} [{self.elapsed():.0f} s]"
        if self._bar is not None:
            self._bar.update()
            self._bar.write(line, file=self.stream)
        elif not self.quiet:
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def elapsed(self) -> float:
        return time.perf_counter() - self._start

    @contextmanager
    def count(self, what: str, total: int):
        """A bar of ``total`` steps (a callable that advances it by one); nothing in a log."""
        if not self.bars or total <= 0:
            yield lambda: None
            return

        with tqdm(total=total, desc=f"{self.label}: {what}", file=self.stream,
                  leave=False) as bar:  # fmt: skip
            yield bar.update
