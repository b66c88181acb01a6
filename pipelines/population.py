"""Population study: identify every muscle (a sweep of the identification study), fit the
hierarchical scaling law, predict each build's model, validate by leaving one muscle out; then
tables, the figure, metrics and the report in a new run folder."""

from __future__ import annotations

from pathlib import Path

from hmid.population import (
    fit_population,
    identify_muscles,
    leave_one_out,
    load_population,
    save_fit,
)
from hmid.population._report import exponent_table
from hmid.population._study import (
    members,
    read_pool,
    settings,
    study_inputs,
    study_metrics,
    write_population,
    write_predicted_models,
)
from hmid.runs import config_json, open_run
from pipelines.sweep import identify


def run(
    config_path: Path,
    *,
    results: Path = Path("results"),
    force: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress=None,
) -> tuple[Path, dict]:
    """Run the population study; returns the new run folder and its metrics."""
    config = load_population(config_path)
    say = progress or (lambda _message: None)
    identified = identify_muscles(
        config,
        Path(results),
        identify,
        force=force,
        workers=workers,
        scheduler=scheduler,
        progress=say,
    )
    inputs = study_inputs(config, identified)
    with open_run(
        Path(results), config.name, Path(config_path), config_json(config), config.seed, inputs
    ) as folder:
        pool = read_pool(config, identified)
        priors, sampler = settings(config)
        say("population fit")
        with folder.manifest.stage("population"):
            fit = fit_population(pool.specs, pool.fits, priors=priors, sampler=sampler)
        save_fit(folder.path, fit, pool.templates[0])
        write_predicted_models(folder.path / "models", fit, config, pool.templates[0])
        forces = params = None
        if config.leave_one_out:
            say("leave one muscle out")
            loo = members(identified, pool)
            with folder.manifest.stage("leave_one_out"):
                forces, params = leave_one_out(
                    loo, priors=priors, sampler=sampler, interval=config.law.interval
                )
        exponents = exponent_table(fit, config.law.interval)
        metrics = study_metrics(fit, exponents, forces, params, config, identified)
        write_population(
            folder.path, fit, pool, exponents, forces, params, metrics, folder.provenance()
        )
    return folder.path, metrics
