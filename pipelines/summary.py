"""Summary study: load -> validate -> denoise -> summarise -> report, into a new run folder."""

from __future__ import annotations

import json
from pathlib import Path

from tqdm import tqdm

from hmid.denoise import denoise_log
from hmid.experiment import load_experiment
from hmid.files import write_json, write_text
from hmid.io import load_column_map, read_log
from hmid.runs import Manifest, config_json, new_run_dir
from hmid.summary import markdown, plot_overview, summarize


def run(config_path: Path, *, results: Path = Path("results"), quiet: bool = False) -> Path:
    """Run the summary study of ``config_path``; returns the run folder."""
    config = load_experiment(config_path)
    resolved = config_json(config)
    run_dir = new_run_dir(results, config.name, resolved)
    manifest = Manifest(run_dir, json.loads(resolved), config.seed)
    manifest.add_input(config_path)
    write_text(run_dir / "config.yaml", Path(config_path).read_text(encoding="utf-8"))
    smoother = config.denoise.smoother.build()
    differentiator = config.denoise.derivative.build()

    logs, summaries = {}, []
    for entry in tqdm(config.logs, desc="logs", unit="log", disable=quiet):
        path, columns_path = config.resolve(entry.path), config.resolve(entry.columns)
        with manifest.stage("load"):
            log = read_log(path, load_column_map(columns_path), rig=config.rig.constants())
        manifest.add_input(path)
        manifest.add_input(columns_path)
        with manifest.stage("denoise"):
            log = denoise_log(log, smoother, differentiator)
        name = path.stem
        logs[name] = log
        summaries.append(summarize(name, entry.role, log))

    with manifest.stage("report"):
        write_json(run_dir / "summary.json", [s.as_dict() for s in summaries])
        write_text(run_dir / "summary.md", markdown(summaries, f"Data summary: {config.name}"))
        dynamic = {n: lg for n, lg in logs.items() if "P" in lg}
        if dynamic:
            plot_overview(dynamic, run_dir / "overview.png")
    manifest.write()
    return run_dir
