"""The report's words: its lead, key facts, verdicts and the sections that only read a run's
artifacts and the tables already written (the rig, the comparison, the data).

:mod:`hmid.pipeline.reporting` writes the files (tables, figures, metrics, the report) and
assembles the document from these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.pipeline.answer import (
    equation_text,
    free_run_text,
    margin_text,
    parameter_lines,
    r2_text,
    rows_text,
)
from hmid.report import Figure, Section, Table

#: The thesis accepted a model at R² above 0.85 (Ch. 4); we apply it to held-out data.
R2_ACCEPT = 0.85


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


def friction_text(estimate) -> str:
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


def rig_section(config, units) -> Section:
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


def coefficient_keys(frame: pd.DataFrame) -> tuple[str, ...]:
    """A coefficient table's name, value, interval and unit (the method and calibration, the
    same on every row, are said in the full table)."""
    keep = ("value", "median", "std. error", "std_err", "ci_", "lower", "upper", "unit")
    return tuple(c for i, c in enumerate(frame.columns) if i == 0 or str(c).startswith(keep))


@dataclass(frozen=True)
class RunTables:
    """The run's own tables (each also written as CSV)."""

    data: pd.DataFrame
    pieces: pd.DataFrame
    fit: pd.DataFrame
    findings: pd.DataFrame | None  # None: no physical-sign finding


def sign_findings(artifacts) -> list:
    """The physical-sign findings: every model's, and the run's own checks of declared
    quantities (a free-fall mass that makes friction negative, a motion's mass)."""
    own = [f for model in artifacts["fit"] for f in model.findings]
    return own + list(artifacts.get("checks", ()))


def data_findings(artifacts) -> tuple:
    """What the plausibility checks found in the data (:mod:`hmid.io.plausibility`)."""
    return (*artifacts["inventory"].findings, *artifacts["rows"].findings)


def key_facts(config, artifacts, unit: str, friction_summary: tuple) -> tuple:
    """The report's key facts after the answer: the rig, the held-out scores, the verdict and
    what else the run found."""
    best = artifacts["compare"].scores.iloc[0]
    findings = sign_findings(artifacts)
    data = data_findings(artifacts)
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


def lead(config, found: dict, unit: str) -> str:
    """The answer first: the winning model, its equation and parameters, its margin over the
    runner-up, its free run and the rows it was scored on."""
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


def comparison_section(config, artifacts, tables: RunTables, figures: list[Figure], out) -> Section:
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


def friction_keys(frame: pd.DataFrame) -> tuple[str, ...]:
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


def data_section(artifacts, tables: RunTables) -> Section:
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
