"""Identification study: load -> denoise -> friction -> reconstruct -> split -> fit -> compare,
then tables, figures, metrics and the report in a new run folder."""

from __future__ import annotations

import json
from pathlib import Path

from hmid.experiment import load_experiment
from hmid.files import write_text
from hmid.pipeline import Runner, Stage
from hmid.pipeline import stages as s
from hmid.pipeline.reporting import write_outputs
from hmid.runs import Manifest, config_json, git_state, new_run_dir, versions


def _section(*names):
    return lambda config: {n: getattr(config, n).model_dump(mode="json") for n in names}


STAGES = (
    Stage("load", s.load, (), s.load_depends),
    Stage("denoise", s.denoise, ("load",), _section("denoise")),
    Stage("friction", s.friction, ("denoise",), _section("friction", "rig", "denoise")),
    Stage("reconstruct", s.reconstruct, ("denoise", "friction"), _section("rig", "friction")),
    Stage("split", s.split, ("reconstruct",), _section("split", "fit")),
    Stage(
        "fit",
        s.fit,
        ("split", "friction"),
        lambda c: {"models": [m.model_dump(mode="json") for m in c.models], "seed": c.seed},
    ),
    Stage("compare", s.compare, ("split", "fit")),
    Stage(
        "loop",
        s.loop,
        ("split",),
        lambda c: {"loop": c.loop.model_dump(mode="json") if c.loop else None},
    ),
)


def analyse(config, stages: tuple[str, ...], cache: Path, *, force: bool = False) -> dict:
    """Run the named stages and those they need (no run folder, no report); the artifacts."""
    by_name = {stage.name: stage for stage in STAGES}
    needed, todo = set(), list(stages)
    while todo:
        name = todo.pop()
        if name not in needed:
            needed.add(name)
            todo.extend(by_name[name].inputs)
    return Runner(cache, force=force).run([s for s in STAGES if s.name in needed], config)


def run(
    config_path: Path, *, results: Path = Path("results"), force: bool = False
) -> tuple[Path, dict]:
    """Run the study; returns the new run folder and the metrics."""
    config = load_experiment(config_path)
    resolved = config_json(config)
    run_dir = new_run_dir(results, config.name, resolved)
    manifest = Manifest(run_dir, json.loads(resolved), config.seed)
    manifest.add_input(config_path)
    for entry in config.logs:
        manifest.add_input(config.resolve(entry.path))
        manifest.add_input(config.resolve(entry.columns))
    write_text(run_dir / "config.yaml", Path(config_path).read_text(encoding="utf-8"))

    runner = Runner(Path(results) / config.name / ".cache", force=force)
    artifacts = runner.run(STAGES, config)
    manifest.stages = {name: r.wall_s for name, r in runner.records.items()}
    manifest.cache = {name: r.cached for name, r in runner.records.items()}
    git = git_state()
    provenance = {
        "config": str(config_path),
        "config sha256": manifest.inputs[str(config_path)],
        "git commit": f"{git['commit']}{' (dirty)' if git['dirty'] else ''}",
        "seed": str(config.seed),
        "run folder": str(run_dir),
        **{f"version {k}": str(v) for k, v in versions().items()},
    }
    with manifest.stage("report"):
        metrics = write_outputs(config, artifacts, run_dir, provenance)
    manifest.write()
    return run_dir, metrics
