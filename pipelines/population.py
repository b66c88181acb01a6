"""Population study: identify every muscle (a sweep of the identification study), fit the
hierarchical scaling law, predict each build's model, validate by leaving one muscle out; then
tables, the figure, metrics and the report in a new run folder."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hmid.files import write_json
from hmid.population import (
    Priors,
    Sampler,
    fit_population,
    identify_muscles,
    leave_one_out,
    load_population,
    predicted_document,
    save_fit,
)
from hmid.population._data import truth
from hmid.population._law import PARAMETERS
from hmid.population._report import exponent_table, law_figure, muscle_table, targets
from hmid.population._summary import from_run
from hmid.population._validate import Member, read_dynamic_logs
from hmid.portable.file import write_model_file
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
    inputs = sorted(
        p for m in identified for p in m.data.iterdir() if p.suffix in (".csv", ".yaml")
    )
    inputs.append(config.resolve(config.experiment))
    with open_run(
        Path(results), config.name, Path(config_path), config_json(config), config.seed, inputs
    ) as folder:
        fits = tuple(from_run(m.name, m.run) for m in identified)
        templates = tuple(
            json.loads((m.run / "models" / "sls.json").read_text(encoding="utf-8"))
            for m in identified
        )
        truths = tuple(_truth(m.data) for m in identified)
        specs = tuple(m.spec() for m in config.muscles)
        priors = Priors(config.law.exponent_sd, config.law.intercept_sd, config.law.scatter_sd)
        s = config.sampler
        sampler = Sampler(s.chains, s.warmup, s.draws, s.target_accept, config.seed)
        say("population fit")
        with folder.manifest.stage("population"):
            fit = fit_population(specs, fits, priors=priors, sampler=sampler)
        save_fit(folder.path, fit, templates[0])
        models = folder.path / "models"
        models.mkdir(exist_ok=True)
        for muscle in config.muscles:
            doc = predicted_document(
                fit,
                muscle.spec(),
                templates[0],
                name=f"{muscle.name}",
                interval=config.law.interval,
                seed=config.seed,
            )
            write_model_file(doc, models / f"{muscle.name}.predicted.json")
        forces = params = None
        if config.leave_one_out:
            say("leave one muscle out")
            loo = tuple(
                Member(m.name, spec, f, t, read_dynamic_logs(m.data), tr)
                for m, spec, f, t, tr in zip(
                    identified, specs, fits, templates, truths, strict=True
                )
            )
            with folder.manifest.stage("leave_one_out"):
                forces, params = leave_one_out(
                    loo, priors=priors, sampler=sampler, interval=config.law.interval
                )
        exponents = exponent_table(fit, config.law.interval)
        metrics = targets(fit, exponents, forces, params)
        metrics["muscles"] = [m.name for m in config.muscles]
        metrics["muscle_runs"] = {m.name: str(m.run) for m in identified}
        _write(
            folder.path, fit, fits, truths, exponents, forces, params, metrics, folder.provenance()
        )
    return folder.path, metrics


def _truth(data: Path) -> np.ndarray | None:
    if not any(data.glob("*.truth.json")):
        return None
    params = truth(data).model_dump()
    return np.array([params[p] for p in PARAMETERS])


def _write(path, fit, fits, truths, exponents, forces, params, metrics, provenance) -> None:
    from hmid.population._document import population_report
    from hmid.report import write_report

    tables = path / "tables"
    tables.mkdir(exist_ok=True)
    figures = path / "figures"
    figures.mkdir(exist_ok=True)
    muscles = muscle_table(fit, fits, truths)
    muscles.to_csv(tables / "muscles.csv", index=False)
    exponents.to_csv(tables / "exponents.csv", index=False)
    fit.diagnostics.to_csv(tables / "diagnostics.csv")
    if forces is not None:
        forces.to_csv(tables / "leave_one_out.csv", index=False)
    if params is not None:
        params.to_csv(tables / "leave_one_out_parameters.csv", index=False)
    figure = law_figure(fit, fits, figures / "law.png")
    write_json(path / "metrics.json", metrics)
    timings = {"population_fit_s": fit.wall_s, "population_fit_cpu_s": fit.cpu_s, "target_s": 60.0}
    if forces is not None:
        timings["leave_one_out_fits_s"] = forces["fit_s"].tolist()
    write_json(path / "timings.json", timings)
    report = population_report(fit, muscles, exponents, forces, params, metrics, figure, provenance)
    write_report(report, path)
