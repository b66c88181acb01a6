"""Control study: load the identified model -> tune the PD -> track every reference with PD
alone and with the model's feed-forward, on proportional and on/off valves -> shake the plant
-> tables, figures, metrics.json and the report, in a new run folder (``hmid control``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import hmid
from hmid.control.config import DEMO, FIBRES, ControlConfig, ModelSection, load_control_config
from hmid.control.inverse import ForceLaw
from hmid.control.report import (
    directions_markdown,
    figures,
    report,
    robustness_markdown,
    tables,
)
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
    models: dict[str, Any]
    if config.ankle is not None:
        models = {name: _model(section, config, config_path, FIBRES)
                  for name, section in config.ankle.models.items()}  # fmt: skip
        study_model: Any = models
    else:
        assert config.model is not None
        models = {"muscle": _model(config.model, config, config_path, DEMO)}
        study_model = models["muscle"]
    inputs = []
    for model in models.values():
        ForceLaw.of(model)  # a model without an inverse is said before a run folder is made
        inputs.append(model.path)
        if model.document.get("posterior"):  # the robustness study's draws
            inputs.append(model.path.parent / model.document["posterior"])
    with open_run(results, config.name, config_path, config_json(config), config.seed,
                  inputs) as folder:  # fmt: skip
        with folder.manifest.stage("study"):
            study = run_study(config, study_model, progress)
        with folder.manifest.stage("report"):
            metrics = _write(study, config, folder.path, [m.path for m in models.values()])
            document = report(study, config, folder.path, metrics, folder.provenance())
            write_report(document, folder.path)
            write_json(folder.path / "metrics.json", metrics)
        return folder.path, metrics


def _model(section: ModelSection, config: ControlConfig, config_path: Path, hint: str):
    """The model a config's model section names (a one-line ConfigError if it is not there)."""
    if section.path is not None:
        return hmid.load_model(config.base_dir / section.path)
    folder_of_run = section.run_folder(config.base_dir, hint)
    model = hmid.load_run(folder_of_run).models.get(section.name)
    if model is None or model.path is None:
        names = sorted(hmid.load_run(folder_of_run).models)
        raise hmid.ConfigError(
            f"{config_path}: model.name {section.name!r} is not a model of "
            f"{folder_of_run} (it has {names})"
        )
    return model


def _met(robust, controller: str, valves: str) -> bool | None:
    """Whether every robustness case of ``controller`` on ``valves`` is within 1.5x."""
    if not len(robust):
        return None
    rows = robust[(robust["controller"] == controller) & (robust["valves"] == valves)]
    return bool(rows["met (<= 1.5x)"].all()) if len(rows) else None


def _write(study: Study, config: ControlConfig, run_dir: Path, model_paths: list) -> dict:
    frames = tables(study)
    for name, frame in frames.items():
        path = run_dir / "tables" / f"{name}.csv"
        path.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(path, index=False)
    directions = "\n".join(
        f"{t.task}:\n\n{table}"
        for t in study.tasks
        if (table := directions_markdown(frames["directions"], t.task))
    )
    if directions:  # the README's tracking-by-direction table, as the study wrote it
        (run_dir / "tables" / "directions.md").write_text(directions, encoding="utf-8")
    if len(frames["robustness"]):  # in brief: the worst ratio and RMSE in sensor steps per case
        (run_dir / "tables" / "robustness.md").write_text(
            robustness_markdown(frames["robustness"]), encoding="utf-8"
        )
    figures(study, run_dir)
    targets, robust = frames["targets"], frames["robustness"]
    proportional = targets[targets["valves"] == "proportional"]
    return {
        "model": study.model,
        "model_file": str(model_paths[0])
        if len(model_paths) == 1
        else [str(p) for p in model_paths],
        "valves": list(study.valves),
        "targets": {
            "reduction_met_proportional": bool(proportional["met (>= 50 %)"].all()),
            "reduction_met_on_off": bool(targets["met (>= 50 %)"].all()),
            # the issue's: FF+PD on the proportional valve, as before FF+PID existed
            "robustness_met": _met(robust, "FF+PD", "proportional"),
            "robustness_met_by": {
                f"{c}, {v}": _met(robust, c, v)
                for c, v in dict.fromkeys(
                    zip(robust.get("controller", []), robust.get("valves", []), strict=True)
                )
            },
        },
        "tables": {name: frame.to_dict(orient="records") for name, frame in frames.items()},
    }
