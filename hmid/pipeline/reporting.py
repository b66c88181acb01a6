"""Turn an identification run's artifacts into files: tables (CSV), figures (PNG), metrics (JSON)
and the report document (Markdown + self-contained HTML)."""

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
from hmid.pipeline.answer import answer, r2_text
from hmid.plots import plot_model, plot_scores
from hmid.report import Figure, Report, Section, Table, write_report
from hmid.workers import Tasks

#: The thesis accepted a model at R² above 0.85 (Ch. 4); we apply it to held-out data.
R2_ACCEPT = 0.85


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


def _verdict(best) -> str:
    r2 = best["r2 (held-out)"]
    # R² as a number (a rounded "100 %" beside "unexplained structure" reads as a
    # contradiction); whether structure remains is the loop's to say, once
    if r2 >= R2_ACCEPT:
        return f"accepted: {best['model']}'s held-out R² {r2_text(r2)} ≥ {R2_ACCEPT}"
    return (
        f"no model reaches R² {R2_ACCEPT} on held-out data (best {r2:.4f}); these families may "
        "lack a physical effect (e.g. viscoelastic memory): see the residuals"
    )


def _friction_text(estimate) -> str:
    lines = []
    for name, value in estimate.params.items():
        lo, hi = estimate.ci[name]
        lines.append(
            f"- **{name}** = {value:.4g} {estimate.units[name]} "
            f"({100 * estimate.confidence:.0f} % CI {lo:.4g} … {hi:.4g})"
        )
    law = estimate.law
    if law is not None:
        lines.append(
            f"\n**Law check:** {law.message()}." if law.rejected else
            f"\n**Law check:** the residuals accept the {law.model} law (runs test p = "
            f"{law.runs_p:.2g}" + (f"; Coulomb + viscous F-test p = {law.f_p:.2g}"
                                  if np.isfinite(law.f_p) else "") + ")."
        )  # fmt: skip
    return "\n".join(lines)


def loop_verdict(config, result) -> str:
    """The loop's verdict; with ``loop.max_effects`` 0 no candidate was screened, so it cannot
    say that nothing is attributable: only what the residual's diagnostics show."""
    if config.loop is None or config.loop.max_effects > 0 or result.effects:
        return result.verdict.value
    from hmid.loop.result import Verdict

    shown = "no pattern" if result.verdict is Verdict.NOTHING_ATTRIBUTABLE else "a pattern"
    return f"nothing screened (loop.max_effects is 0); the residual's diagnostics show {shown}"


def loop_summary(result, verdict: str | None = None) -> tuple[tuple[str, str], ...]:
    if result is None:
        return ()
    added = ", ".join(e.title for e in result.effects) or "no effect added"
    return (
        (
            "closing the loop",
            f"{verdict or result.verdict.value}: {added}; held-out RMSE (one-step) "
            f"{result.base_name} "
            f"{result.before.rmse:.4g} → {result.after_name} {result.after.rmse:.4g} "
            f"{result.unit}",
        ),
    )


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


def _rig_section(config, units) -> Section:
    rig = config.rig
    terms = []
    for term in rig.balance:
        how = "model family" if term.kind == "model" else ("known" if term.known else "fitted")
        terms.append(
            {
                "term": term.name,
                "kind": term.kind,
                "sign": "+" if term.sign > 0 else "−",
                "regressor": "the model family's force"
                if term.kind == "model"
                else term.regressor(),
                "coefficient": how,
                "physically positive": term.positive if term.kind != "model" else None,
                "description": term.description,
            }
        )
    channels = ", ".join(
        f"{c} [{units[c]}]" + (" (logged with the opposite sign)" if s.sign < 0 else "")
        for c, s in rig.channels.items()
    )
    text = (
        f"**{rig.name}**. {rig.convention}\n\n"
        f"Explained quantity: **{rig.explained.name}** [{units['target']}] = the sum of the "
        f"terms below. Channels: {channels}"
        + (f"; v and a derived from {rig.position}" if rig.position else "")
        + ". Both sides pass through the same zero-phase moving average "
        f"({1e3 * config.denoise.smoother.window_s:g} ms)."
    )
    return Section("Rig: the declared force balance", text=text,
                   tables=(Table(pd.DataFrame(terms), "Terms of the balance"),))  # fmt: skip


def _coefficient_keys(frame: pd.DataFrame) -> tuple[str, ...]:
    """A coefficient table's name, value, interval and unit (the method and calibration, the
    same on every row, are said in the full table)."""
    keep = ("value", "median", "std. error", "std_err", "ci_", "lower", "upper", "unit")
    return tuple(c for i, c in enumerate(frame.columns) if i == 0 or str(c).startswith(keep))


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
                        key_columns=_coefficient_keys(coefficients),
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


@dataclass(frozen=True)
class _Tables:
    """The run's own tables (each also written as CSV)."""

    data: pd.DataFrame
    pieces: pd.DataFrame
    fit: pd.DataFrame
    findings: pd.DataFrame | None  # None: no physical-sign finding


def _tables(artifacts, units, out: _Folders) -> _Tables:
    inventory = artifacts["inventory"]
    data = pd.DataFrame([s.row(units) for s in inventory.summaries])
    out.csv(data, "data_summary.csv")
    pieces = pd.DataFrame([r.__dict__ for r in inventory.pieces])
    out.csv(pieces, "pieces.csv")
    fit_table = _fit_table(artifacts, units["target"])
    out.csv(fit_table, "fit_table.csv")
    out.csv(artifacts["compare"].scores, "held_out_scores.csv")
    findings = _findings(artifacts)
    findings_table = None
    if findings:
        findings_table = pd.DataFrame([f.to_dict() for f in findings])
        out.csv(findings_table, "sign_findings.csv")
    return _Tables(data, pieces, fit_table, findings_table)


def _findings(artifacts) -> list:
    """The physical-sign findings: every model's, and the run's own checks of declared
    quantities (a free-fall mass that makes friction negative, a motion's mass)."""
    own = [f for model in artifacts["fit"] for f in model.findings]
    return own + list(artifacts.get("checks", ()))


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
        f"{config.friction.v_min} m/s.\n\n{_friction_text(estimate)}",
        tables=(
            Table(
                table, "Friction per free-fall log and pooled", key_columns=_friction_keys(table)
            ),
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
        "sign_findings": [f.to_dict() for f in _findings(artifacts)],
        "friction": None if estimate is None else estimate.to_dict(),
        "rows": {"train": rows.train, "validation": rows.validation, "excluded": rows.excluded},
        "flags": list(artifacts["inventory"].flags),
        "data_findings": [f.to_dict() for f in _data_findings(artifacts)],
    }
    failed = getattr(fitted, "failed", ())  # models left out, each with its reason
    if failed:
        metrics["failed"] = [f.__dict__ for f in failed]
    if metrics_loop is not None:  # its wall times go to timings.json: metrics are reproducible
        metrics["loop"] = {k: v for k, v in metrics_loop.items() if k != "wall_s"}
    return metrics


def _data_findings(artifacts) -> tuple:
    """What the plausibility checks found in the data (:mod:`hmid.io.plausibility`)."""
    return (*artifacts["inventory"].findings, *artifacts["rows"].findings)


def _summary(config, artifacts, unit: str, friction_summary: tuple) -> tuple:
    """The report's key facts after the answer: the rig, the held-out scores, the verdict and
    what else the run found."""
    best = artifacts["compare"].scores.iloc[0]
    findings = _findings(artifacts)
    data = _data_findings(artifacts)
    data_summary = (("⚠ data plausibility", "; ".join(f.message() for f in data)),) if data else ()
    loop = artifacts.get("loop")
    verdict = None if loop is None else loop_verdict(config, loop)
    failed = getattr(artifacts["fit"], "failed", ())
    failed_summary = (("⚠ failed fits", "; ".join(f.message() for f in failed)),) if failed else ()
    sign_summary: tuple[tuple[str, str], ...] = ()
    if findings:
        sign_summary = (
            ("⚠ physical-sign check", f"{len(findings)} parameter(s) fitted with an impossible "
             "sign: " + "; ".join(f.message() for f in findings)),
        )  # fmt: skip
    return (
        ("rig", config.rig.name),
        (
            "held-out R² / NRMSE fit (one-step)",
            f"{r2_text(best['r2 (held-out)'])} / {best['nrmse_fit_pct (held-out)']:.1f} %",
        ),
        ("held-out max |error|", f"{best['max_abs_error (held-out)']:.4g} {unit}"),
        ("verdict", _verdict(best)),
        *data_summary,
        *sign_summary,
        *failed_summary,
        *friction_summary,
        *loop_summary(artifacts.get("loop"), verdict),
    )


def _lead(config, found: dict, unit: str) -> str:
    """The answer first: the winning model, its equation and parameters, its margin over the
    runner-up, its free run and the rows it was scored on."""
    from hmid.pipeline.answer import (
        equation_text,
        free_run_text,
        margin_text,
        parameter_lines,
        r2_text,
        rows_text,
    )

    one = found["one_step"]
    head = (f"**{found['model']}** predicts {config.rig.explained.name} best on held-out rows: "
            f"one-step RMSE **{one['rmse']:.4g} {unit}**, R² {r2_text(one['r2'])}")  # fmt: skip
    free = free_run_text(found)
    parts = [head + (f"; {free}." if free else "."), f"`{equation_text(found)}`"]
    parts.append("\n".join(f"- {line}" for line in parameter_lines(found)))
    margin = margin_text(found, unit)
    if margin:
        parts.append(margin[0].upper() + margin[1:] + ".")
    parts.append(rows_text(found)[0].upper() + rows_text(found)[1:] + ".")
    return "\n\n".join(parts)


#: The held-out scores a reader compares first (the page shows the rest behind a toggle).
SCORE_KEYS = ("model", "error kind", "rmse (held-out)", "r2 (held-out)",
              "nrmse_fit_pct (held-out)", "max_abs_error (held-out)")  # fmt: skip


def _comparison_section(config, artifacts, tables: _Tables, figures: list[Figure], out) -> Section:
    label = config.rig.explained.name
    findings = (
        () if tables.findings is None else (Table(tables.findings, "Physical-sign findings"),)
    )
    return Section(
        "Model comparison on held-out data",
        text=f"All errors are **one-step**: {label} (less its known terms) predicted "
        "from the measured signals at each held-out sample. Held-out rows are the "
        f"{config.split.kind.replace('_', ' ')} split, never used for fitting. A model "
        "**with memory** (SLS) carries its internal state through each log from the "
        "measured position alone, never from the measured force; free-run simulations, "
        "where a family has them, are in its own section.",
        tables=(
            Table(
                artifacts["compare"].scores,
                "Held-out errors per model (sorted by RMSE)",
                key_columns=SCORE_KEYS,
            ),
            Table(tables.fit, _fit_caption(config), key_columns=_fit_keys(tables.fit)),
            *findings,
        ),
        figures=(Figure(out.figures / "scores.png", "Held-out RMSE and NRMSE fit"), *figures),
    )


def _friction_keys(frame: pd.DataFrame) -> tuple[str, ...]:
    keep = ("log", "n", "RMSE", "τ_int")
    return tuple(c for c in frame.columns if str(c).startswith(keep) or
                 (str(c).startswith("F") and "load cell" not in str(c)))  # fmt: skip


def _data_keys(frame: pd.DataFrame) -> tuple[str, ...]:
    keep = ("name", "role", "samples", "duration_s", "rate_hz", "peak_speed", "at_rest_fraction")
    return tuple(c for c in frame.columns if c in keep)


def _logs_summary(data: pd.DataFrame) -> str:
    roles = data["role"].value_counts() if "role" in data else pd.Series(dtype=int)
    return f"{len(data)} logs: " + ", ".join(f"{n} {role}" for role, n in roles.items())


def _pieces_summary(pieces: pd.DataFrame) -> str:
    unused = int((~pieces["used"].astype(bool)).sum()) if "used" in pieces else 0
    return f"{len(pieces)} pieces, {unused} too short to filter"


def _fit_caption(config) -> str:
    caption = "Fit on training rows, error on held-out rows"
    return caption + (" (Table 4.1 for this run)" if on_thesis_rig(config) else "")


def on_thesis_rig(config) -> bool:
    """Whether the rig is the thesis's own (the Hydro Muscle's Ch. 4 rig), where the report may
    point to the thesis's tables."""
    return "thesis" in config.rig.name.lower()


def _fit_keys(frame: pd.DataFrame) -> tuple[str, ...]:
    wanted = ("model", "terms", "R² (train)", "RMSE train", "RMSE held-out", "R² held-out", "BIC")
    return tuple(c for c in frame.columns if c.startswith(wanted))


def _data_section(artifacts, tables: _Tables) -> Section:
    flags = list(artifacts["inventory"].flags)
    return Section(
        "Data",
        text="Findings from validation:\n\n"
        + ("\n".join(f"- {f}" for f in flags) if flags else "- none"),
        tables=(
            Table(
                tables.data,
                "Logs as loaded (SI, rig's sign convention) and denoised",
                key_columns=_data_keys(tables.data),
                summary=_logs_summary(tables.data),
                collapsed=True,
            ),
            Table(
                tables.pieces,
                "Pieces between logger pauses (used: False where a piece is too short to filter)",
                summary=_pieces_summary(tables.pieces),
                collapsed=True,
            ),
        ),
    )


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
        lead=_lead(config, found, units["target"]),
        summary=_summary(config, artifacts, units["target"], friction_summary),
        sections=(
            _rig_section(config, units),
            _comparison_section(config, artifacts, tables, model_figures, out),
            *free_sections,
            *loop_sections,
            Section(
                "Model parameters" + (" (cf. thesis Table 4.2)" if on_thesis_rig(config) else ""),
                subsections=tuple(coefficient_sections),
            ),
            *friction_sections,
            _data_section(artifacts, tables),
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
