"""Turn an identification run's artifacts into files: tables (CSV), figures (PNG), metrics (JSON)
and the report document (Markdown + self-contained HTML), assembled from the report's words
(:mod:`hmid.pipeline.report_text`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hmid.experiment import log_units
from hmid.files import atomic_path, write_json
from hmid.pipeline.answer import answer
from hmid.pipeline.report_text import (
    RunTables,
    coefficient_keys,
    comparison_section,
    data_findings,
    data_section,
    friction_keys,
    friction_text,
    key_facts,
    lead,
    loop_verdict,
    on_thesis_rig,
    rig_section,
    sign_findings,
)
from hmid.plots import plot_model, plot_scores
from hmid.report import Figure, Report, Section, Table, write_report
from hmid.workers import Tasks


def _shown(model: str) -> set[str]:
    """The prediction columns one model's figure reads."""
    return {"log", "t", "target", model, f"{model} lower", f"{model} upper"}


def _csv(frame: pd.DataFrame, path: Path) -> Path:
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)
    return path


def _fit_table(artifacts, unit: str) -> pd.DataFrame:
    """Training fit and held-out error per model (the thesis's Table 4.1, on its own rig)."""
    scores = artifacts["compare"].scores.set_index("model")
    rows = []
    for model in artifacts["fit"]:
        s = model.fit_summary
        held = scores.loc[model.name]
        rows.append(
            {
                "model": model.name,
                "terms": s.n_params,
                "R² (train)": s.r2,
                "adj. R² (train)": s.r2_adj,
                f"RMSE train [{unit}]": s.rmse,
                f"RMSE held-out [{unit}]": held["rmse (held-out)"],
                "R² held-out": held["r2 (held-out)"],
                "AIC": s.aic,
                "BIC": s.bic,
                "cond. (scaled)": s.condition_number,
            }
        )
    return pd.DataFrame(rows)


def _interval(model) -> dict:
    """The intervals' level, method and calibration status, for metrics.json."""
    note = model.interval
    if note is None:
        return {}
    fields = ("level", "method", "status", "tau_int", "calibrated_to")
    return {"intervals": {name: getattr(note, name) for name in fields}}


def _parameters(model) -> dict:
    """The declared parameters of a balance fit: value, interval and unit by name."""
    table = model.coefficients
    low, high = (c for c in table.columns if c.startswith("ci_"))
    return {
        str(row["parameter"]): {"value": float(row["value"]), "lower": float(row[low]),
                                "upper": float(row[high]), "unit": str(row["unit"])}
        for _, row in table.iterrows()
    }  # fmt: skip


def _model_sections(
    fitted, out: _Folders, scores: pd.DataFrame
) -> tuple[list[Section], list[tuple[Any, Path]]]:
    """Each model's parameters and its family's extras (the best model's open, the others on
    request); and the figures the families ask for, with the file each is to be drawn to."""
    rmse = dict(zip(scores["model"], scores["rmse (held-out)"], strict=True))
    best = scores.iloc[0]["model"]
    sections, wanted = [], []
    for model in fitted:
        safe = model.name.replace(":", "_")
        coefficients = model.coefficient_table()
        out.csv(coefficients, f"coefficients_{safe}.csv")
        text = f"`{model.equation}`" + "".join(f"\n\n- {note}" for note in model.notes)
        extra_tables: list[Table] = []
        extra_figures: list[Figure] = []
        extras = model.model.report_extras()
        if extras is not None:  # e.g. MCMC diagnostics of a Bayesian family
            text += "\n\n" + extras.text if extras.text else ""
            for frame, caption in extras.tables:
                out.csv(frame, f"{safe}_{len(extra_tables)}.csv")
                extra_tables.append(Table(frame, caption))
            for spec in extras.figures:
                path = out.figures / f"{safe}_{spec.file}"
                wanted.append((spec, path))
                extra_figures.append(Figure(path, spec.caption, collapsed=True))
        sections.append(
            Section(
                model.name,
                collapsed=model.name != best,
                summary=f"held-out RMSE {rmse.get(model.name, np.nan):.4g}",
                text=text,
                tables=(
                    Table(
                        coefficients,
                        f"Parameters of {model.name}: units and intervals",
                        key_columns=coefficient_keys(coefficients),
                    ),
                    *extra_tables,
                ),
                figures=tuple(extra_figures),
            )
        )
    return sections, wanted


def simulator_truths(config) -> dict:
    """The simulator's rig as its truth files state it (``<log>.truth.json``, which ``hmid
    simulate`` writes beside each log): their ``rig`` section where every dynamic log has one
    and they agree; empty otherwise."""
    found: list = []
    for entry in config.logs_with_role("dynamic"):
        path = config.resolve(entry.path).with_suffix(".truth.json")
        try:
            rig = json.loads(path.read_text(encoding="utf-8")).get("rig")
        except (OSError, ValueError, AttributeError):
            return {}
        if not isinstance(rig, dict) or (found and rig != found[0]):
            return {}
        found.append(rig)
    return found[0] if found else {}


#: What a worker draws with (a light module: the same plot for every model)
FIGURE_MODULES = ("matplotlib.figure", "hmid.plots")


@dataclass(frozen=True)
class _Folders:
    """A run folder's ``tables/`` and ``figures/``."""

    tables: Path
    figures: Path

    @classmethod
    def make(cls, run_dir: Path) -> _Folders:
        folders = cls(run_dir / "tables", run_dir / "figures")
        folders.tables.mkdir(exist_ok=True)
        folders.figures.mkdir(exist_ok=True)
        return folders

    def csv(self, frame: pd.DataFrame, name: str) -> Path:
        return _csv(frame, self.tables / name)


def _tables(artifacts, units, out: _Folders) -> RunTables:
    inventory = artifacts["inventory"]
    data = pd.DataFrame([s.row(units) for s in inventory.summaries])
    out.csv(data, "data_summary.csv")
    pieces = pd.DataFrame([r.__dict__ for r in inventory.pieces])
    out.csv(pieces, "pieces.csv")
    fit_table = _fit_table(artifacts, units["target"])
    out.csv(fit_table, "fit_table.csv")
    out.csv(artifacts["compare"].scores, "held_out_scores.csv")
    findings = sign_findings(artifacts)
    findings_table = None
    if findings:
        findings_table = pd.DataFrame([f.to_dict() for f in findings])
        out.csv(findings_table, "sign_findings.csv")
    return RunTables(data, pieces, fit_table, findings_table)


def _draw(drawing, wanted, config, artifacts, units, out: _Folders) -> list[Figure]:
    """Queue every figure of the models with ``drawing``: the families' own first, the dear ones
    (a posterior's corner plot) before the rest, so that a worker begins them while this
    process, once done with the tables, takes back the cheap ones from the end. Returns the
    comparison's figures of each model."""
    truths = simulator_truths(config)
    for spec, path in sorted(wanted, key=lambda item: not item[0].dear):  # stable
        draw = partial(spec.draw, truths=truths) if spec.takes_truth and truths else spec.draw
        drawing.submit(draw, *spec.args, path)
    comparison = artifacts["compare"]
    drawing.submit(plot_scores, comparison.scores, out.figures / "scores.png", units["target"])
    figures, best = [], comparison.scores.iloc[0]["model"]
    for model in artifacts["fit"]:
        path = out.figures / f"model_{model.name.replace(':', '_')}.png"
        shown = [c for c in comparison.predictions if c in _shown(model.name)]
        drawing.submit(plot_model, comparison.predictions[shown], model.name, path,
                       config.rig.explained.name, units["target"])  # fmt: skip
        figures.append(Figure(path, f"{model.name} on held-out data (one-step error)",
                              collapsed=model.name != best))  # fmt: skip
    # the best model's first: the others are shown on request
    return sorted(figures, key=lambda f: f.collapsed)


def _loop(config, artifacts, out: _Folders, drawing) -> tuple[tuple[Section, ...], dict | None]:
    if artifacts.get("loop") is None:
        return (), None
    from hmid.loop.report import loop_section

    # its wall times go to timings.json, not the report: two runs' reports are the same
    result = replace(artifacts["loop"], costs=())
    section, metrics = loop_section(result, out.figures, out.csv, drawing=drawing)
    verdict = metrics["verdict"] = loop_verdict(config, result)
    if verdict != result.verdict.value:
        section = replace(section, text=section.text.replace(result.verdict.value, verdict, 1))
    return (section,), metrics


def _friction(config, artifacts, out: _Folders) -> tuple[tuple[Section, ...], tuple]:
    """The free-fall friction's section (figure drawn here) and summary lines."""
    estimate = artifacts["friction"]
    if estimate is None:
        return (), ()
    from hmid.friction import plot_free_fall

    figure = out.figures / "friction.png"
    free_falls = list(artifacts["inventory"].free_falls)
    plot_free_fall(free_falls, estimate, figure, config.rig.position)
    table = estimate.table()
    out.csv(table, "friction.csv")
    section = Section(
        "Rig friction from free-fall tests",
        text=f"Model: {config.friction.model}; sliding segments with |v| > "
        f"{config.friction.v_min} m/s.\n\n{friction_text(estimate)}",
        tables=(
            Table(table, "Friction per free-fall log and pooled", key_columns=friction_keys(table)),
        ),
        figures=(Figure(figure, "Free-fall motion and fitted model", collapsed=True),),
    )
    summary = tuple(
        (f"friction from free falls: {name}",
         f"{value:.4g} {estimate.units[name]}, {100 * estimate.confidence:.0f} % CI "
         f"{estimate.ci[name][0]:.4g} … {estimate.ci[name][1]:.4g}")
        for name, value in estimate.params.items()
    )  # fmt: skip
    if estimate.law is not None and estimate.law.rejected:
        summary += (("friction law", estimate.law.message()),)
    return (section,), summary


def _metrics(config, artifacts, units, metrics_loop: dict | None) -> dict:
    comparison, fitted, estimate = artifacts["compare"], artifacts["fit"], artifacts["friction"]
    rows, label = artifacts["rows"], config.rig.explained.name
    metrics = {
        "experiment": config.name,
        "rig": config.rig.name,
        "explained": {"name": label, "unit": units["target"]},
        "error_kind": f"one-step: {label} predicted from the measured signals at each sample",
        "best_model": str(comparison.scores.iloc[0]["model"]),
        "held_out": comparison.scores.replace({np.nan: None}).to_dict(orient="records"),
        "fit": [{"model": m.name, **m.fit_summary.to_dict(), **_interval(m)} for m in fitted],
        "parameters": {m.name: _parameters(m) for m in fitted if m.family == "balance"},
        "sign_findings": [f.to_dict() for f in sign_findings(artifacts)],
        "friction": None if estimate is None else estimate.to_dict(),
        "rows": {"train": rows.train, "validation": rows.validation, "excluded": rows.excluded},
        "flags": list(artifacts["inventory"].flags),
        "data_findings": [f.to_dict() for f in data_findings(artifacts)],
    }
    failed = getattr(fitted, "failed", ())  # models left out, each with its reason
    if failed:
        metrics["failed"] = [f.__dict__ for f in failed]
    if metrics_loop is not None:  # its wall times go to timings.json: metrics are reproducible
        metrics["loop"] = {k: v for k, v in metrics_loop.items() if k != "wall_s"}
    return metrics


def _portable(config, artifacts, units, run_dir: Path, out: _Folders, drawing) -> tuple:
    """The model files (``models/``), each model's free run on the held-out blocks (table and
    figure): the section and the metrics' entries."""
    from hmid.pipeline.models_out import free_run_section, write_models

    model_files = write_models(artifacts["fit"], artifacts.get("export") or {}, run_dir)
    section, table = free_run_section(config, artifacts.get("freerun") or {}, units, out, drawing)
    records = table.replace({np.nan: None}).to_dict(orient="records")
    return (section,) if section else (), {"model_files": model_files, "free_run": records}


def write_outputs(
    config,
    artifacts: dict[str, Any],
    run_dir: Path,
    provenance: dict,
    drawing=None,
    progress=None,
) -> dict:
    """Write every table, figure, metrics.json and the report; returns the metrics. The
    figures the models ask for are drawn by ``drawing`` (:class:`~hmid.workers.Tasks`;
    default: its own, started here) while this process writes the rest; ``progress`` (a
    :class:`hmid.progress.Progress`) counts them."""
    drawing = Tasks().start(FIGURE_MODULES) if drawing is None else drawing
    run_dir = Path(run_dir).resolve()  # figure paths must not depend on the working directory
    out = _Folders.make(run_dir)
    units = log_units(config)
    tables = _tables(artifacts, units, out)
    coefficient_sections, wanted = _model_sections(
        artifacts["fit"], out, artifacts["compare"].scores
    )
    model_figures = _draw(drawing, wanted, config, artifacts, units, out)
    loop_sections, metrics_loop = _loop(config, artifacts, out, drawing)
    friction_sections, friction_summary = _friction(config, artifacts, out)
    free_sections, portable = _portable(config, artifacts, units, run_dir, out, drawing)
    found = answer(config, artifacts, pd.DataFrame(portable["free_run"]))
    metrics = _metrics(config, artifacts, units, metrics_loop) | portable | {"answer": found}
    write_json(run_dir / "metrics.json", metrics)
    report = Report(
        title=f"hmid identification report: {config.name}",
        lead=lead(config, found, units["target"]),
        summary=key_facts(config, artifacts, units["target"], friction_summary),
        sections=(
            rig_section(config, units),
            comparison_section(config, artifacts, tables, model_figures, out),
            *free_sections,
            *loop_sections,
            Section(
                "Model parameters" + (" (cf. thesis Table 4.2)" if on_thesis_rig(config) else ""),
                subsections=tuple(coefficient_sections),
            ),
            *friction_sections,
            data_section(artifacts, tables),
        ),
        provenance=provenance,
    )
    if progress is None:
        drawing.results()  # the report embeds the figures
    else:
        with progress.count("figures", drawing.queued) as step:
            drawing.results(step)
    write_report(report, run_dir)
    return metrics
