"""Blind suite: simulate logs with an undeclared effect, run the standard identification stages
through the loop, and tabulate whether the loop named the right physics.

Each case simulates its data set into a temporary folder, runs load -> denoise -> friction ->
reconstruct -> split -> loop (pipelines.identify), and keeps only its outcome
(``cases/<id>.json``). The run folder holds the suite config, every outcome, the table
(effect x strength) and the pass marks.
"""

from __future__ import annotations

import json
import tempfile
import warnings
from collections.abc import Callable
from concurrent.futures import as_completed
from pathlib import Path
from typing import Any

import pandas as pd
import yaml
from pydantic import ValidationError

from hmid._messages import format_validation_error
from hmid.balance import RigSection
from hmid.blind import (
    Case,
    check_targets,
    dataset_for,
    declare,
    experiment_for,
    load_suite,
    outcome,
    plan_cases,
    suite_counts,
    suite_table,
)
from hmid.errors import ConfigError, HmidWarning
from hmid.experiment import ExperimentConfig, experiment_from
from hmid.files import write_json, write_text
from hmid.report.markdown import markdown_table
from hmid.runs import open_run
from hmid.sweep import open_executor


def check_template(template: dict, source: str, suite=None) -> None:
    """The experiment template is valid with logs filled in, and the suite's expected effects
    are candidates its rig is offered (before any case runs)."""
    try:
        rig = RigSection.model_validate(template.get("rig"))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, f"{source}: rig", RigSection)) from None
    roles = ("dynamic", "free_fall") if rig.from_free_fall else ("dynamic",)
    probe = [{"path": "probe.csv", "columns": "probe.yaml", "role": role} for role in roles]
    try:
        config = ExperimentConfig.model_validate({**template, "logs": probe})
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, ExperimentConfig)) from None
    if config.loop is None:
        raise ConfigError(f"{source}: the experiment template needs a 'loop' section")
    if suite is not None:
        from hmid.loop import Setting

        offered = set(config.loop.candidate_names(Setting.of(config.rig)))
        suite.check_expectations(offered, f"{source} (loop.candidates)")


def run_case(case: Case, dataset: dict, experiment: dict, source: str) -> dict[str, Any]:
    """One case, in a worker: simulate, analyse through the loop, return the outcome."""
    from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
    from hmid.simulate.write import write_dataset
    from pipelines.identify import analyse

    with tempfile.TemporaryDirectory(prefix="hmid-blind-") as tmp:
        folder = Path(tmp) / "data"
        write_dataset(HydroMuscleDataset.model_validate(dataset_for(dataset, case)), folder)
        index = yaml.safe_load((folder / "index.yaml").read_text(encoding="utf-8"))["logs"]
        declared = declare(experiment, case)  # a known term declared wrong, where the case does
        config = experiment_from(experiment_for(declared, folder, index), source, folder)
        # findings (an effect may drive a sensor to its rails) go in the outcome, not the console
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", HmidWarning)
            artifacts = analyse(config, ("loop",), Path(tmp) / "cache")
        found = sorted({str(w.message) for w in caught if issubclass(w.category, HmidWarning)})
        return outcome(case, artifacts["loop"]) | {"findings": len(found)}


def run(
    suite_path: Path,
    *,
    results: Path = Path("results"),
    workers: int | None = None,
    progress: Callable[[dict], None] | None = None,
) -> tuple[Path, pd.DataFrame, pd.DataFrame]:
    """Run every case; returns the run folder, the table and the pass marks."""
    suite = load_suite(suite_path)
    dataset_path, experiment_path = suite.resolve(suite.dataset), suite.resolve(suite.experiment)
    dataset = yaml.safe_load(dataset_path.read_text(encoding="utf-8"))
    experiment = yaml.safe_load(experiment_path.read_text(encoding="utf-8"))
    check_template(experiment, str(experiment_path), suite)  # template errors first, in one line
    resolved = json.dumps(suite.model_dump(mode="json", exclude={"base_dir"}), sort_keys=True)
    with open_run(results, suite.name, Path(suite_path), resolved, suite.seed,
                  [dataset_path, experiment_path], copy_as="suite.yaml") as folder:  # fmt: skip
        table, targets = _run_cases(suite, dataset, experiment, str(experiment_path), folder,
                                    workers, progress)  # fmt: skip
    return folder.path, table, targets


def _run_cases(suite, dataset, experiment, source, folder, workers, progress):
    run_dir, manifest = folder.path, folder.manifest
    cases = plan_cases(suite)
    rows = []
    section = suite.executor.with_options(workers=workers, scheduler=None)
    with manifest.stage("cases"), open_executor(section) as executor:
        futures = {
            executor.submit(run_case, case, dataset, experiment, source): case for case in cases
        }
        for future in as_completed(futures):
            case = futures[future]
            try:
                row = future.result()
            except Exception as err:  # a failed case is reported and counts as wrong
                row = case.to_dict() | {"verdict": f"error: {err}", "correct": False}
            write_json(run_dir / "cases" / f"{case.case_id}.json", row)
            rows.append(row)
            if progress:
                progress(row)
    order = {case.case_id: i for i, case in enumerate(cases)}
    outcomes = pd.DataFrame(rows).sort_values("case_id", key=lambda c: c.map(order))
    table, targets = suite_table(outcomes), check_targets(outcomes, suite)
    counts = suite_counts(outcomes)
    outcomes.to_csv(run_dir / "outcomes.csv", index=False)
    table.to_csv(run_dir / "blind.csv", index=False)
    targets.to_csv(run_dir / "targets.csv", index=False)
    counts.to_csv(run_dir / "counts.csv", index=False)
    write_text(run_dir / "blind.md", _markdown(suite, table, targets, counts))
    return table, targets


def _markdown(suite, table: pd.DataFrame, targets: pd.DataFrame, counts: pd.DataFrame) -> str:
    return (
        f"# Blind suite {suite.name}\n\n"
        f"{suite.seeds} seeds per effect and strength, {suite.clean_seeds} clean controls. "
        "Held-out RMSE is one-step, median over the runs, on rows no decision of the loop saw; "
        "'right first' is the share of runs whose first added effect is an expected candidate, "
        "alone or in a set the loop calls indistinguishable on the data; 'confidently wrong' is "
        "the share whose first effect is a single unexpected name (any name on clean data or for "
        "an effect outside the library).\n\n"
        f"{markdown_table(table)}\n\n## Pass marks\n\n{markdown_table(targets)}\n\n"
        f"## Counts over every run\n\n{markdown_table(counts)}\n"
    )
