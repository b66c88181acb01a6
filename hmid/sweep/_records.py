"""One run of a sweep as the workers see it: the task shipped out, the record that comes back.

:func:`run_task` executes in a worker process (a local pool or a Dask worker), so it and the work
function it calls must be importable top-level functions. It writes the run's config, calls the
work function, and saves the outcome atomically in ``done/<run-id>.json`` before returning it:
a run counts as finished exactly when its done file exists, whatever happens to the process that
submitted it.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import socket
import time
import traceback
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from hmid.errors import HmidError, one_line
from hmid.files import write_json, write_text

#: ``work(config_path, results, force) -> (run folder, summary)``: one run of the study. The
#: summary maps table column names to values (numbers or short strings).
Work = Callable[[Path, Path, bool], tuple[Path, Mapping[str, Any]]]


class RunRecord(BaseModel):
    """How one run ended: its summary (``status == "ok"``) or its one-line ``error``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    run_id: str
    status: Literal["ok", "failed"]
    error: str | None = None
    overrides: dict[str, Any]
    summary: dict[str, Any] = {}
    run_dir: str | None = None  # the study's own folder, relative to the sweep folder
    wall_s: float
    warnings: tuple[str, ...] = ()
    traceback: str | None = None  # for errors that are not hmid's own (bugs)
    worker: str = ""  # host:pid of the process that ran it
    finished: str = ""


@dataclass(frozen=True)
class RunTask:
    """What a worker needs for one run; every path absolute (workers may run elsewhere)."""

    run_id: str
    overrides: dict[str, Any]
    config: dict[str, Any]  # the experiment config with the overrides applied
    folder: str  # the sweep folder
    force: bool = False
    header: str = ""  # comment lines on top of the written config

    @property
    def run_folder(self) -> Path:
        return Path(self.folder) / "runs" / self.run_id


def done_path(folder: Path, run_id: str) -> Path:
    return Path(folder) / "done" / f"{run_id}.json"


def read_done(folder: Path, run_id: str) -> RunRecord | None:
    """The record of a finished run, or None (never finished, or an unreadable record)."""
    path = done_path(folder, run_id)
    if not path.is_file():
        return None
    try:
        return RunRecord.model_validate(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError, ValidationError):
        warnings.warn(f"{path}: unreadable run record; the run is done again", stacklevel=2)
        return None


def run_task(work: Work, task: RunTask) -> RunRecord:
    """Run one task in this process and record its outcome in the sweep's done folder."""
    start = time.perf_counter()
    outcome: dict[str, Any] = {"status": "ok"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            config_path = task.run_folder / "config.yaml"
            text = yaml.safe_dump(task.config, sort_keys=False, allow_unicode=True)
            write_text(config_path, task.header + text)
            run_dir, summary = work(config_path, task.run_folder, task.force)
            outcome["run_dir"] = _relative(Path(run_dir), Path(task.folder))
            outcome["summary"] = dict(summary)
        except Exception as err:  # one bad run must not stop the sweep: report it
            outcome = {"status": "failed", "error": one_line(err, 500, name_foreign=True)}
            if not isinstance(err, HmidError):
                outcome["traceback"] = traceback.format_exc()
    record = RunRecord(
        run_id=task.run_id,
        overrides=task.overrides,
        wall_s=round(time.perf_counter() - start, 3),
        warnings=tuple(dict.fromkeys(" ".join(str(w.message).split()) for w in caught)),
        worker=f"{socket.gethostname()}:{os.getpid()}",
        finished=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        **outcome,
    )
    write_json(done_path(Path(task.folder), task.run_id), record.model_dump(mode="json"))
    return record


def _relative(path: Path, folder: Path) -> str:
    try:
        return path.resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:  # the work function chose a folder elsewhere
        return str(path.resolve())


def lost_record(task: RunTask, err: BaseException) -> RunRecord:
    """A run whose worker died or was lost: failed, but not recorded as done (rerun next time)."""
    reason = one_line(err, 500, name_foreign=True)
    return RunRecord(
        run_id=task.run_id,
        status="failed",
        error=f"the worker was lost, the run will be repeated: {reason}",
        overrides=task.overrides,
        wall_s=float("nan"),
    )
