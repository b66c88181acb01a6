"""Summary study: load -> validate -> denoise -> summarise -> plausibility -> report, into a new
run folder."""

from __future__ import annotations

import warnings
from pathlib import Path

from hmid.errors import HmidWarning
from hmid.experiment import load_experiment, log_units
from hmid.files import write_json, write_text
from hmid.pipeline import Runner
from hmid.pipeline.stages import plausibility
from hmid.runs import config_json, open_run
from hmid.summary import markdown, plot_overview, summarize
from pipelines.identify import STAGES


def run(config_path: Path, *, results: Path = Path("results"), quiet: bool = False) -> Path:
    """Run the summary study of ``config_path``; returns the run folder."""
    config = load_experiment(config_path)
    inputs = [config.resolve(p) for e in config.logs for p in (e.path, e.columns)]
    with open_run(
        results, config.name, config_path, config_json(config), config.seed, inputs
    ) as folder:
        runner = Runner(Path(results) / config.name / ".cache")
        artifacts = runner.run([s for s in STAGES if s.name in ("load", "denoise")], config)
        folder.manifest.stages = {name: r.wall_s for name, r in runner.records.items()}
        channels = list(config.rig.log_channels)
        summaries = [
            summarize(name, item.role, item.pieces, channels)
            for name, item in artifacts["denoise"].items()
        ]
        found = plausibility(config, artifacts["load"], summaries)
        for finding in found:
            warnings.warn(finding.message(), HmidWarning, stacklevel=2)
        with folder.manifest.stage("report"):
            write_json(folder.path / "summary.json", [s.as_dict() for s in summaries])
            text = markdown(summaries, log_units(config), f"Data summary: {config.name}")
            text += (
                "\n## Plausibility from physics\n\n"
                + ("\n".join(f"- {f.message()}" for f in found) or "- nothing implausible")
                + "\n"
            )
            write_text(folder.path / "summary.md", text)
            dynamic = {n: i.pieces for n, i in artifacts["denoise"].items() if i.role == "dynamic"}
            plot_overview(dynamic, channels, folder.path / "overview.png")
    return folder.path
