"""The population study's steps around the population fit, for ``pipelines/population.py`` to
wire: what the identified muscles' runs say, the sampler's settings, the predicted models, the
muscles that leave-one-out reads, the metrics, and the tables, figure and report written."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.files import write_json
from hmid.population._config import PopulationConfig
from hmid.population._data import truth_values
from hmid.population._identify import Identified
from hmid.population._model import PopulationFit, Priors, Sampler
from hmid.population._predict import predicted_document
from hmid.population._report import law_figure, muscle_table, targets
from hmid.population._summary import MuscleFit, from_run
from hmid.population._validate import Member, read_dynamic_logs
from hmid.portable.file import write_model_file
from hmid.simulate.specs import MuscleSpec


@dataclass(frozen=True)
class Pool:
    """What the study reads of its identified muscles, in the config's order."""

    fits: tuple[MuscleFit, ...]
    templates: tuple[dict, ...]  # each muscle's own SLS model file's content
    truths: tuple[np.ndarray | None, ...]  # the simulator's parameters, where known
    specs: tuple[MuscleSpec, ...]


def study_inputs(config: PopulationConfig, identified: tuple[Identified, ...]) -> list[Path]:
    """The files the run depends on: every muscle's data set and the per-muscle experiment."""
    inputs = sorted(
        p for m in identified for p in m.data.iterdir() if p.suffix in (".csv", ".yaml")
    )
    inputs.append(config.resolve(config.experiment))
    return inputs


def read_pool(config: PopulationConfig, identified: tuple[Identified, ...]) -> Pool:
    """Each muscle's own SLS fit, its model file, its truth and its build."""
    fits = tuple(from_run(m.name, m.run) for m in identified)
    templates = tuple(
        json.loads((m.run / "models" / "sls.json").read_text(encoding="utf-8")) for m in identified
    )
    truths = tuple(truth_values(m.data) for m in identified)
    specs = tuple(m.spec() for m in config.muscles)
    return Pool(fits, templates, truths, specs)


def settings(config: PopulationConfig) -> tuple[Priors, Sampler]:
    """The law's priors and the NUTS settings the config declares (seeded by the study's)."""
    law = config.law
    priors = Priors(law.exponent_sd, law.intercept_sd, law.scatter_typical, law.scatter_log_sd)
    s = config.sampler
    return priors, Sampler(s.chains, s.warmup, s.draws, s.target_accept, config.seed)


def write_predicted_models(
    models: Path, fit: PopulationFit, config: PopulationConfig, template: dict
) -> None:
    """Each muscle's model as the law predicts it from its build, ``<muscle>.predicted.json``."""
    models.mkdir(exist_ok=True)
    for muscle in config.muscles:
        doc = predicted_document(
            fit,
            muscle.spec(),
            template,
            name=f"{muscle.name}",
            interval=config.law.interval,
            seed=config.seed,
        )
        write_model_file(doc, models / f"{muscle.name}.predicted.json")


def members(identified: tuple[Identified, ...], pool: Pool) -> tuple[Member, ...]:
    """The muscles as leave-one-out reads them (their dynamic logs read here)."""
    return tuple(
        Member(m.name, spec, f, t, read_dynamic_logs(m.data), tr)
        for m, spec, f, t, tr in zip(
            identified, pool.specs, pool.fits, pool.templates, pool.truths, strict=True
        )
    )


def study_metrics(
    fit: PopulationFit,
    exponents: pd.DataFrame,
    forces: pd.DataFrame | None,
    params: pd.DataFrame | None,
    config: PopulationConfig,
    identified: tuple[Identified, ...],
) -> dict:
    """The targets, measured, and which muscles (and their runs) the study pooled."""
    metrics = targets(fit, exponents, forces, params)
    metrics["muscles"] = [m.name for m in config.muscles]
    metrics["muscle_runs"] = {m.name: str(m.run) for m in identified}
    return metrics


def write_population(
    path: Path,
    fit: PopulationFit,
    pool: Pool,
    exponents: pd.DataFrame,
    forces: pd.DataFrame | None,
    params: pd.DataFrame | None,
    metrics: dict,
    provenance: dict,
) -> None:
    """Tables, the figure, metrics.json, timings.json and the report into the run folder."""
    from hmid.population._document import population_report
    from hmid.report import write_report

    tables = path / "tables"
    tables.mkdir(exist_ok=True)
    figures = path / "figures"
    figures.mkdir(exist_ok=True)
    muscles = muscle_table(fit, pool.fits, pool.truths)
    muscles.to_csv(tables / "muscles.csv", index=False)
    exponents.to_csv(tables / "exponents.csv", index=False)
    fit.diagnostics.to_csv(tables / "diagnostics.csv")
    if forces is not None:
        forces.to_csv(tables / "leave_one_out.csv", index=False)
    if params is not None:
        params.to_csv(tables / "leave_one_out_parameters.csv", index=False)
    figure = law_figure(fit, pool.fits, figures / "law.png")
    write_json(path / "metrics.json", metrics)
    timings = {"population_fit_s": fit.wall_s, "population_fit_cpu_s": fit.cpu_s, "target_s": 60.0}
    if forces is not None:
        timings["leave_one_out_fits_s"] = forces["fit_s"].tolist()
    write_json(path / "timings.json", timings)
    report = population_report(fit, muscles, exponents, forces, params, metrics, figure, provenance)
    write_report(report, path)
