"""Sweep study: the identification study (pipelines.identify) over many logs or settings.

Each run of the sweep is one identification run into ``results/<sweep>/runs/<run id>/``; the
table compares the runs by best model, held-out RMSE of every model, and the friction estimate.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

from hmid.sweep import RunRecord, SweepOutcome, SweepPlan, execute, load_sweep, plan_sweep


def summarize(metrics: dict) -> dict[str, Any]:
    """The table columns of one identification run, from its metrics."""
    unit = metrics["explained"]["unit"]
    out: dict[str, Any] = {"rig": metrics["rig"], "best model": metrics["best_model"]}
    held_out = {row["model"]: row for row in metrics["held_out"]}  # sorted by RMSE
    out["best R² (held-out)"] = held_out[metrics["best_model"]]["r2 (held-out)"]
    for model in [fit["model"] for fit in metrics["fit"]]:  # in config order: stable columns
        out[f"RMSE {model} [{unit}]"] = held_out[model]["rmse (held-out)"]
    for model, table in metrics.get("parameters", {}).items():
        for name, row in table.items():
            out[f"{model}: {name} [{row['unit']}]"] = row["value"]
    friction = metrics["friction"]
    for name, value in (friction or {}).get("params", {}).items():
        out[f"friction {name} [{friction['units'][name]}]"] = value
    loop = metrics.get("loop")
    if loop is not None:
        out["loop"] = f"{loop['verdict']}: " + (
            " + ".join(e["name"] for e in loop["effects"]) or "nothing added"
        )
        out[f"loop RMSE before → after [{unit}]"] = (
            f"{loop['held_out_before']['rmse']:.4g} → {loop['held_out_after']['rmse']:.4g}"
        )
    return out


def identify(config_path: Path, results: Path, force: bool) -> tuple[Path, dict[str, Any]]:
    """Work function of a sweep: one identification run (executes in a worker process)."""
    from pipelines.identify import run as identify_run

    run_dir, metrics = identify_run(config_path, results=results, force=force)
    return run_dir, summarize(metrics)


def plan(
    config_path: Path,
    *,
    results: Path = Path("results"),
    force: bool = False,
    retry_failed: bool = False,
) -> SweepPlan:
    """Every run of the sweep in ``config_path``, and which finished before (see plan_sweep)."""
    return plan_sweep(load_sweep(config_path), results, force=force, retry_failed=retry_failed)


def run(
    config_path: Path,
    *,
    results: Path = Path("results"),
    force: bool = False,
    retry_failed: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    limit: int | None = None,
    progress: Callable[[RunRecord], None] | None = None,
) -> SweepOutcome:
    """Plan the sweep and execute its pending runs; returns the table and the counts."""
    sweep_plan = plan(config_path, results=results, force=force, retry_failed=retry_failed)
    return execute(
        sweep_plan,
        identify,
        workers=workers,
        scheduler=scheduler,
        executor=executor,
        limit=limit,
        progress=progress,
    )
