"""Control study: load the identified model -> tune the PD -> track every reference with PD
alone and with the model's feed-forward, on proportional and on/off valves -> shake the plant
-> tables, figures, metrics.json and the report, in a new run folder (``hmid control``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import hmid
from hmid.control.config import ControlConfig, load_control_config
from hmid.control.inverse import ForceLaw
from hmid.control.report import figures, report, tables
from hmid.control.study import Study, run_study
from hmid.files import write_json
from hmid.report import write_report
from hmid.runs import config_json, open_run


def run(
    config_path: Path,
    *,
    results: Path = Path("results"),
    progress: Callable[[str], None] | None = None,
) -> tuple[Path, dict]:
    """Run the control study of ``config_path``; returns the run folder and its metrics."""
    config = load_control_config(config_path)
    folder_of_run = config.run_folder()
    model = hmid.load_run(folder_of_run).models.get(config.model.name)
    if model is None or model.path is None:
        names = sorted(hmid.load_run(folder_of_run).models)
        raise hmid.ConfigError(
            f"{config_path}: model.name {config.model.name!r} is not a model of "
            f"{folder_of_run} (it has {names})"
        )
    ForceLaw.of(model)  # a model without an inverse is said before a run folder is made
    inputs = [model.path]
    if model.document.get("posterior"):  # the robustness study's draws
        inputs.append(model.path.parent / model.document["posterior"])
    with open_run(results, config.name, config_path, config_json(config), config.seed,
                  inputs) as folder:  # fmt: skip
        with folder.manifest.stage("study"):
            study = run_study(config, model, progress)
        with folder.manifest.stage("report"):
            metrics = _write(study, config, folder.path, model.path)
            document = report(study, config, folder.path, metrics, folder.provenance())
            write_report(document, folder.path)
            write_json(folder.path / "metrics.json", metrics)
        return folder.path, metrics


def _write(study: Study, config: ControlConfig, run_dir: Path, model_path: Path) -> dict:
    frames = tables(study)
    for name, frame in frames.items():
        path = run_dir / "tables" / f"{name}.csv"
        path.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(path, index=False)
    figures(study, run_dir)
    targets, robust = frames["targets"], frames["robustness"]
    proportional = targets[targets["valves"] == "proportional"]
    return {
        "model": study.model,
        "model_file": str(model_path),
        "valves": list(study.valves),
        "targets": {
            "reduction_met_proportional": bool(proportional["met (>= 50 %)"].all()),
            "reduction_met_on_off": bool(targets["met (>= 50 %)"].all()),
            "robustness_met": bool(robust["met (<= 1.5x)"].all()) if len(robust) else None,
        },
        "tables": {name: frame.to_dict(orient="records") for name, frame in frames.items()},
    }
