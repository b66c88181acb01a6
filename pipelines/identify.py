"""Identification study: load -> denoise -> friction -> signals -> split -> fit -> export ->
compare -> loop (the exported models' free runs beside the last two, in the run's worker), then
tables, figures, metrics and the report in a new run folder."""

from __future__ import annotations

import time
import warnings
from functools import partial
from pathlib import Path

from hmid.config import read_yaml
from hmid.errors import ConfigError, DataError, HmidWarning
from hmid.experiment import ExperimentConfig, load_experiment
from hmid.files import write_json
from hmid.pipeline import Runner, Stage
from hmid.pipeline import stages as s
from hmid.pipeline.reporting import FIGURE_MODULES, write_outputs
from hmid.runs import config_json, open_run
from hmid.workers import Tasks

#: What a worker screens the loop's candidates with (:mod:`hmid.loop.parallel`; columns carry
#: their units, from pint's registry)
LOOP_MODULES = ("hmid.loop.parallel", "jax", "hmid.io.units:unit_registry")


def _section(*names):
    return lambda config: {n: getattr(config, n).model_dump(mode="json") for n in names}


STAGES = (
    # the data stages are redone on every run (fast); the cache holds results, not copies of logs
    Stage("load", s.load, (), s.load_depends, store=False),
    Stage("denoise", s.denoise, ("load",), _section("denoise", "rig"), store=False),
    Stage("inventory", s.inventory, ("load", "denoise"), store=False),
    Stage("friction", s.friction, ("denoise",), _section("friction", "rig", "denoise")),
    Stage(
        "signals",
        s.signals,
        ("denoise", "friction"),
        _section("rig", "fit", "denoise"),
        store=False,
    ),
    Stage("split", s.split, ("signals",), _section("split"), store=False),
    Stage("checks", s.checks, ("split", "friction"), store=False),
    Stage(
        "fit",
        s.fit,
        ("split", "friction"),
        lambda c: {"models": [m.model_dump(mode="json") for m in c.models], "seed": c.seed},
    ),
    Stage("export", s.export, ("split", "fit", "friction"), _section("denoise", "fit")),
    Stage("rows", s.rows, ("split",), store=False),
    Stage("freerun_blocks", s.freerun_blocks, ("split", "export"), store=False),
    # the free runs go on in the worker while the run compares the models and runs the loop;
    # with no worker they run once the loop is done (the signals are let go before they import
    # JAX)
    Stage("freerun", s.freerun, ("freerun_blocks", "fit", "export"), started=True),
    Stage("compare", s.compare, ("split", "fit")),
    Stage(
        "loop",
        s.loop,
        ("split", "fit", "friction"),
        lambda c: {"loop": c.loop.model_dump(mode="json") if c.loop else None},
    ),
)


#: What the report reads: the logs, as loaded and as smoothed, are let go once the signals exist,
#: and the signals once the last stage has read them.
REPORTED = (
    "inventory",
    "friction",
    "checks",
    "rows",
    "fit",
    "compare",
    "loop",
    "export",
    "freerun",
)


def analyse(config: ExperimentConfig, stages: tuple[str, ...], cache: Path, *, force=False) -> dict:
    """Run the named stages and those they need (no run folder, no report); the artifacts."""
    by_name = {stage.name: stage for stage in STAGES}
    needed, todo = set(), list(stages)
    while todo:
        name = todo.pop()
        if name not in needed:
            needed.add(name)
            todo.extend(by_name[name].inputs)
    return Runner(cache, force=force).run([s for s in STAGES if s.name in needed], config)


def data_findings(artifacts: dict) -> tuple:
    """What the physics makes implausible in the logs (:mod:`hmid.io.plausibility`)."""
    held = (artifacts.get("inventory"), artifacts.get("rows"))
    return tuple(f for part in held if part is not None for f in part.findings)


def sign_findings(artifacts: dict) -> tuple:
    """Parameters fitted with a sign physics forbids: every family's, the rig's own."""
    fitted = tuple(f for model in artifacts["fit"] for f in model.findings)
    return (*fitted, *(artifacts.get("checks") or ()))


def findings(artifacts: dict) -> list[str]:
    """What the run must say on the console: models that failed, implausible data, physical
    signs that fail, a friction law that the free falls reject."""
    out = [failed.message() for failed in getattr(artifacts["fit"], "failed", ())]
    out += [finding.message() for finding in data_findings(artifacts)]
    out += [finding.message() for finding in sign_findings(artifacts)]
    if artifacts.get("friction") is not None:  # a friction level of the wrong sign
        out.extend(artifacts["friction"].impossible())
    law = artifacts["friction"].law if artifacts.get("friction") is not None else None
    if law is not None and law.rejected:
        out.append(law.message())
    if artifacts.get("loop") is not None:  # a base that fell back, an addition that did worse
        out.extend(artifacts["loop"].notes)
    return out


def worker_imports(config_path: Path) -> tuple[str, ...]:
    """What a worker imports first for this experiment: its families' modules, read from the
    file before it is validated, so that the worker starts on them while the run loads (nothing
    if the file does not say: validation reports it, with the file's name)."""
    from hmid.families import FAMILIES

    try:
        families = [FAMILIES[entry["family"]] for entry in read_yaml(config_path)["models"]]
    except (ConfigError, KeyError, TypeError):
        return ()
    return _imports(families)


def _imports(families) -> tuple[str, ...]:
    return tuple(dict.fromkeys(m for family in families for m in family.imports))


def run(
    config_path: Path,
    *,
    results: Path = Path("results"),
    force: bool = False,
    strict=False,
    progress=None,
) -> tuple[Path, dict]:
    """Run the study; returns the new run folder and the metrics. ``strict``: a finding about
    the data or a sign is an error (the folder is marked failed). ``progress`` (a
    :class:`hmid.progress.Progress`) shows the stages, the report's among them."""
    config = load_experiment(config_path)
    inputs = [config.resolve(p) for e in config.logs for p in (e.path, e.columns)]
    resolved = config_json(config)
    with open_run(results, config.name, config_path, resolved, config.seed, inputs) as folder:
        # the worker imports what a stage needs while the run works before it: the families'
        # modules now, the loop's and the figures' once the families are handed out
        workers = Tasks().start(_imports(type(spec) for spec in config.models))
        later = (*(LOOP_MODULES if config.loop else ()), *FIGURE_MODULES)
        runner = Runner(Path(results) / config.name / ".cache", force=force)
        if progress is not None:
            progress.stages([*(stage.name for stage in STAGES), "report"])
        artifacts = runner.run(
            STAGES,
            config,
            keep=REPORTED,
            before={"compare": partial(workers.start, later)},
            progress=progress,
        )
        folder.manifest.stages = {name: r.wall_s for name, r in runner.records.items()}
        folder.manifest.work = {name: r.work_s for name, r in runner.records.items()
                                if r.work_s is not None}  # fmt: skip
        folder.manifest.cache = {name: r.cached for name, r in runner.records.items()}
        folder.manifest.reused = {f.name: f.reused for f in artifacts["fit"] if f.reused}
        said = findings(artifacts)
        if strict and said:
            more = f" (and {len(said) - 1} more finding(s))" if len(said) > 1 else ""
            raise DataError(f"--strict: {said[0]}{more}")
        for message in said:  # said on every run, the cached ones too
            warnings.warn(message, HmidWarning, stacklevel=2)
        with folder.manifest.stage("report"):
            if progress is not None:
                progress.started("report")
            start = time.perf_counter()
            metrics = write_outputs(config, artifacts, folder.path, folder.provenance(), workers,
                                    progress)  # fmt: skip
            if progress is not None:
                progress.done("report", time.perf_counter() - start, None)
                progress.close()
        write_json(folder.path / "timings.json", timings(runner, artifacts))
    return folder.path, metrics


def timings(runner: Runner, artifacts: dict) -> dict:
    """Wall times, kept out of metrics.json so that two runs give the same bytes there: each
    stage's, the loop's parts', and each sampler's."""
    loop = artifacts.get("loop")
    samplers = {
        model.name: float(model.model.result.wall_s)
        for model in artifacts["fit"]
        if hasattr(getattr(model.model, "result", None), "wall_s")
    }
    work = {name: r.work_s for name, r in runner.records.items() if r.work_s is not None}
    return {
        "stages_s": {name: r.wall_s for name, r in runner.records.items()},
        "stages_work_s": work,
        "loop_s": [
            {"part": part, "seconds": seconds, "candidates": n} for part, seconds, n in loop.costs
        ]
        if loop is not None
        else [],
        "samplers_s": samplers,
    }
