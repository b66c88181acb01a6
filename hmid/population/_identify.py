"""Each muscle identified by the standard pipeline, the muscles in parallel through the sweep.

The population's muscles are the runs of one sweep (:mod:`hmid.sweep`): the per-muscle
experiment config with each muscle's logs. So they share its executor (a local process pool or a
Dask cluster), its records (a muscle identified before, on the same data and settings, is not
identified again) and its stage caches.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from hmid.errors import HmidError
from hmid.population._config import PopulationConfig
from hmid.population._data import ensure_data, experiment_overrides
from hmid.sweep import SweepConfig, Work, execute, plan_sweep, read_done


@dataclass(frozen=True)
class Identified:
    """One muscle's identification: its data folder and its run folder."""

    name: str
    data: Path
    run: Path


def identify_muscles(
    config: PopulationConfig,
    results: Path,
    work: Work,
    *,
    force: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[Identified, ...]:
    """Simulate missing data sets, then identify every muscle (runs finished before are read
    back); the muscles' run folders in the config's order. ``work`` runs one identification
    (:func:`pipelines.sweep.identify`)."""
    folders = ensure_data(config, progress)
    sweep = SweepConfig(
        name=f"{config.name}-muscles",
        base=config.resolve(config.experiment),
        runs=tuple(
            experiment_overrides(config, m, f) for m, f in zip(config.muscles, folders, strict=True)
        ),
        executor=config.executor,
        base_dir=config.base_dir,
    )
    plan = plan_sweep(sweep, results, force=force)
    for run in plan.runs:
        if run.error is not None:
            raise HmidError(f"muscle {config.muscles[run.number - 1].name}: {run.error}")
    if plan.pending:
        if progress is not None:
            progress(f"identifying {len(plan.pending)} muscle(s)")
        execute(plan, work, workers=workers, scheduler=scheduler)
    out = []
    for run, muscle, folder in zip(plan.runs, config.muscles, folders, strict=True):
        assert run.run_id is not None
        record = read_done(plan.folder, run.run_id)
        if record is None or record.status != "ok" or record.run_dir is None:
            said = record.error if record is not None else "no record"
            raise HmidError(f"muscle {muscle.name}: its identification failed: {said}")
        out.append(Identified(muscle.name, folder, plan.folder / record.run_dir))
    return tuple(out)
