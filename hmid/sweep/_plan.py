"""Planning a sweep: each run's experiment config, its run id, and which runs finished before.

Planning reads but writes nothing. A run's id hashes its validated experiment config together with
the SHA-256 of every log and column map it reads, so a run is skipped on resume only when both
its settings and its data are unchanged. Overrides that give no valid experiment (an unknown key,
a bad value, a log file that does not exist) make a failed run at once, with the reason.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hmid.config import read_yaml
from hmid.errors import ConfigError
from hmid.files import sha256
from hmid.runs import config_json
from hmid.sweep._config import SweepConfig, apply_overrides
from hmid.sweep._records import RunRecord, RunTask, read_done


@dataclass(frozen=True)
class PlannedRun:
    """One run of the sweep: its overrides and resolved config, or why there is none."""

    number: int  # 1-based position in the sweep
    overrides: dict[str, Any]
    run_id: str | None = None  # None when the overrides give no valid experiment
    config: dict[str, Any] | None = None  # experiment config data, log paths absolute
    error: str | None = None


@dataclass(frozen=True)
class SweepPlan:
    """Every run of a sweep and the records of those that finished before (``done``)."""

    sweep: SweepConfig
    folder: Path  # results/<sweep name>, absolute
    runs: tuple[PlannedRun, ...]
    done: Mapping[str, RunRecord] = field(default_factory=dict)
    force: bool = False

    @property
    def pending(self) -> tuple[PlannedRun, ...]:
        """Valid runs without a usable record: the ones to execute."""
        return tuple(r for r in self.runs if r.run_id is not None and r.run_id not in self.done)

    def task(self, run: PlannedRun) -> RunTask:
        if run.run_id is None or run.config is None:
            raise ValueError(f"run {run.number} has no valid config: {run.error}")
        lines = [f"hmid sweep {self.sweep.name}, run {run.number} (id {run.run_id})"]
        lines.append(f"base: {self.sweep.base_path.resolve()}")
        lines += [f"override {k}: {json.dumps(v)}" for k, v in run.overrides.items()]
        lines.append("log paths are absolute")
        header = "".join(f"# {' '.join(line.split())}\n" for line in lines)
        return RunTask(run.run_id, run.overrides, run.config, str(self.folder), self.force, header)


def _absolute_logs(data: dict[str, Any], folder: Path) -> dict[str, Any]:
    """``data`` with relative log and column-map paths made absolute against ``folder``."""
    logs = data.get("logs")
    for entry in logs if isinstance(logs, list) else ():
        for key in ("path", "columns"):
            value = entry.get(key) if isinstance(entry, dict) else None
            if isinstance(value, str) and not Path(value).is_absolute():
                entry[key] = os.path.normpath(folder.resolve() / value)
    return data


def _resolve(sweep: SweepConfig, base: dict[str, Any], run: PlannedRun, hashes: dict) -> PlannedRun:
    from hmid.experiment import experiment_from

    data = _absolute_logs(apply_overrides(base, run.overrides), sweep.base_dir)
    config = experiment_from(data, f"run {run.number}", sweep.base_dir)
    inputs = []
    for entry in config.logs:
        for key in ("path", "columns"):
            path = getattr(entry, key)
            if path not in hashes:
                hashes[path] = sha256(path)
            inputs.append(hashes[path])
    digest = hashlib.sha256(json.dumps([config_json(config), inputs]).encode()).hexdigest()
    return PlannedRun(run.number, run.overrides, digest[:12], data)


def plan_sweep(
    sweep: SweepConfig,
    results: str | Path = "results",
    *,
    force: bool = False,
    retry_failed: bool = False,
) -> SweepPlan:
    """Resolve every run of ``sweep`` and find those already finished in ``results/<name>``.

    ``force`` ignores earlier records (every valid run is executed again, its stages
    recomputed); ``retry_failed`` executes again only the runs that failed.
    """
    base = _absolute_logs(read_yaml(sweep.base_path), sweep.base_path.parent)
    folder = (Path(results) / sweep.name).resolve()
    runs: list[PlannedRun] = []
    hashes: dict[Any, str] = {}  # a log's path (or column map's) -> its digest
    seen: dict[str, int] = {}
    for number, overrides in enumerate(sweep.override_sets(), start=1):
        run = PlannedRun(number, overrides)
        try:
            run = _resolve(sweep, base, run, hashes)
        except ConfigError as err:
            run = PlannedRun(number, overrides, error=str(err))
        if run.run_id in seen:
            raise ConfigError(
                f"sweep {sweep.name!r}: runs {seen[run.run_id]} and {number} give the same "
                "experiment on the same data; remove one"
            )
        if run.run_id is not None:
            seen[run.run_id] = number
        runs.append(run)
    done: dict[str, RunRecord] = {}
    for run in runs:
        if force or run.run_id is None:
            continue
        record = read_done(folder, run.run_id)
        if record is not None and not (retry_failed and record.status == "failed"):
            done[run.run_id] = record
    return SweepPlan(sweep, folder, tuple(runs), done, force)
