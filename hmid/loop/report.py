"""The loop's report section, tables and metrics."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.balance.inference import CALIBRATED_TAU
from hmid.loop.plots import plot_pattern, plot_whiteness
from hmid.loop.result import AddedEffect, LoopResult
from hmid.report import Figure, Section, Table
from hmid.workers import draw


def before_after(result: LoopResult) -> pd.DataFrame:
    """Held-out scores of the base, after each added effect in turn, and after all."""
    rows = []
    unit = result.unit
    labelled = [(f"before: {result.base_name}", result.before)]
    name = result.base_name
    for effect, scores in result.steps[:-1]:
        name += f" + {effect}"
        labelled.append((f"step: {name}", scores))
    labelled.append((f"after: {result.after_name}", result.after))
    for label, s in labelled:
        rows.append(
            {
                "model": label,
                "error kind": s.kind,
                f"held-out RMSE [{unit}]": s.rmse,
                f"max |error| [{unit}]": s.max_abs_error,
                "NRMSE fit [%]": s.nrmse_fit_pct,
                "R²": s.r2,
                "rows": s.n,
            }
        )
    return pd.DataFrame(rows)


def diagnostics_table(result: LoopResult) -> pd.DataFrame:
    rows = []
    for label, d in (("before", result.diagnostics_before), ("after", result.diagnostics_after)):
        signal, eta2 = d.strongest
        rows.append(
            {
                "residual": label,
                f"RMS train [{result.unit}]": d.rms,
                "τ_int [samples]": d.tau_int,
                "Ljung-Box p": d.ljung_box_p,
                "Ljung-Box n": d.ljung_box_n,
                "max |ACF| beyond lag 0": float(np.max(np.abs(d.acf[1:]))),
                **{f"max |ccf| {k}": float(np.nanmax(np.abs(d.ccf[k]))) for k in d.ccf.columns},
                "strongest signal": signal,
                "η² (cross-fitted)": eta2,
                **{f"η² {k}": v for k, v in d.pattern["eta2"].items()},
            }
        )
    return pd.DataFrame(rows)


def metrics(result: LoopResult) -> dict:
    return {
        "base": result.base_name,
        "after": result.after_name,
        "verdict": result.verdict.value,
        "message": result.message,
        "notes": list(result.notes),
        "final_model": list(result.final_lines()),
        "error_kind": "one-step",
        "held_out_before": result.before.to_dict(),
        "held_out_after": result.after.to_dict(),
        "effects": [
            {
                "name": e.name,
                "evidence": e.evidence,
                "parameters": e.parameters.replace({np.nan: None}).to_dict(orient="records"),
                "indistinguishable_from": [
                    {
                        "name": a.name,
                        "cv_gap": a.gap,
                        "separating": a.separating,
                        "parameters": a.parameters.replace({np.nan: None}).to_dict(
                            orient="records"
                        ),
                    }
                    for a in e.alternatives
                ],
            }
            for e in result.effects
        ],
        "hint": (
            {
                "terms": result.hint.terms.to_dict(orient="records"),
                "heldout_r2": result.hint.heldout_r2,
                "periodic": result.hint.periodic,
            }
            if result.hint is not None
            else None
        ),
        "wall_s": [
            {"part": part, "seconds": seconds, "candidates": n} for part, seconds, n in result.costs
        ],
    }


def loop_section(
    result: LoopResult,
    figures: Path,
    write_csv,
    *,
    prefix: str = "loop",
    title: str = "Closing the loop: residual analysis and missing physics",
    drawing=None,
) -> tuple[Section, dict]:
    """The report section; ``write_csv(frame, name)`` stores a table in the run folder; file
    names start with ``prefix``; ``drawing`` may draw the figures that read only the
    diagnostics (see :func:`~hmid.workers.draw`)."""
    light = replace(result, data=None, residual_before=np.empty(0), residual_after=np.empty(0))
    draw(drawing, plot_whiteness, light, figures / f"{prefix}_whiteness.png")
    plot_pattern(result, figures / f"{prefix}_structure.png")
    table, diag = before_after(result), diagnostics_table(result)
    write_csv(table, f"{prefix}_before_after.csv")
    write_csv(diag, f"{prefix}_diagnostics.csv")
    write_csv(result.tests, f"{prefix}_tests.csv")
    write_csv(result.final_parameters, f"{prefix}_final_model.csv")
    effect_sections = tuple(_effect_section(e, prefix, write_csv) for e in result.effects)
    hint_tables, hint_text = _hint(result, prefix, write_csv)
    section = Section(
        title,
        text="".join(f"**⚠ {note}**\n\n" for note in result.notes)
        + f"**Verdict: {result.verdict.value}.** {result.message}{hint_text}\n\n"
        + _final_text(result)
        + _method_text(result),
        tables=(*_tables(result, table, diag), *hint_tables),
        figures=_figures(result, figures, prefix),
        subsections=effect_sections,
    )
    return section, metrics(result)


def _tables(result: LoopResult, table: pd.DataFrame, diag: pd.DataFrame) -> tuple[Table, ...]:
    """The section's tables: before and after, the final and the base model, every test, and
    the residual diagnostics."""
    tests = result.tests
    return (
        Table(table, "Held-out error before and after (one-step)"),
        Table(
            result.final_parameters,
            f"The final model, {result.after_name}: every parameter after the loop (part: "
            "the base's or an added effect's), from its last joint fit, with intervals",
        ),
        Table(
            result.base_parameters,
            f"{result.base_name}: its terms refitted by least squares, with intervals",
            summary=f"{len(result.base_parameters)} parameters",
            collapsed=True,
        ),
        Table(
            tests,
            "Every candidate tested, per round",
            key_columns=_keys(tests, TEST_KEYS),
            summary=f"{len(tests)} tests of candidate effects",
            collapsed=True,
        ),
        Table(
            diag,
            "Residual diagnostics on training rows",
            key_columns=_keys(diag, DIAGNOSTIC_KEYS),
        ),
    )


def _figures(result: LoopResult, figures: Path, prefix: str) -> tuple[Figure, ...]:
    # nothing added: the figures show what the tests found, on request
    return (
        Figure(
            figures / f"{prefix}_structure.png",
            "Where the residual's structure is",
            collapsed=not result.effects,
        ),
        Figure(
            figures / f"{prefix}_whiteness.png",
            "Whiteness and independence, before and after",
            collapsed=not result.effects,
        ),
    )


#: The columns of the tests and the diagnostics a reader reads first (the page shows the rest
#: behind a toggle; the CSV has them all).
TEST_KEYS = ("round", "candidate", "F", "p (Holm)", "ΔBIC", "passes training", "CV change",
             "selected", "added")  # fmt: skip
DIAGNOSTIC_KEYS = ("residual", "RMS train", "τ_int", "Ljung-Box p", "max |ACF|",
                   "strongest signal", "η² (cross-fitted)")  # fmt: skip


def _keys(frame, wanted: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(c for c in frame.columns if isinstance(c, str) and c.startswith(wanted))


def _effect_section(e: AddedEffect, prefix: str, write_csv) -> Section:
    """An added effect: its physics, evidence and parameters, and its indistinguishable
    rivals."""
    write_csv(e.parameters, f"{prefix}_effect_{e.name}.csv")
    rivals = []
    for a in e.alternatives:
        write_csv(a.parameters, f"{prefix}_effect_{e.name}_or_{a.name}.csv")
        rivals.append(
            Section(
                f"Indistinguishable from it: {a.title}",
                text=(
                    f"Physics: {a.physics}.\n\nIts out-of-fold RMSE is "
                    f"{100 * a.gap:+.2f} % of the added effect's, not clearly worse. "
                    f"To tell them apart: {a.separating}."
                ),
                tables=(Table(a.parameters, f"{a.title}: parameters, units and intervals"),),
            )
        )
    return Section(
        f"Added: {e.title}" if not e.alternatives else f"Added: {e.verdict()}",
        text=f"Physics: {e.physics}.\n\nEvidence: {e.evidence}.",
        tables=(Table(e.parameters, f"{e.title}: parameters, units and intervals"),),
        subsections=tuple(rivals),
    )


def _final_text(result: LoopResult) -> str:
    """The final model, one line per part (the base, each added effect)."""
    lines = result.final_lines()
    if not lines:
        return ""
    return f"**Final model: {result.after_name}.**\n\n" + "".join(f"- {x}\n" for x in lines) + "\n"


def _hint(result: LoopResult, prefix: str, write_csv) -> tuple[tuple[Table, ...], str]:
    """The data-driven hint's table (where it explains held-out variance) and its periodicity
    sentence (where it found one)."""
    hint = result.hint
    tables: tuple[Table, ...] = ()
    text = ""
    if hint is not None and hint.heldout_r2 > 0:
        write_csv(hint.terms, f"{prefix}_hint.csv")
        tables = (
            Table(
                hint.terms,
                "Data-driven hint, not an identified effect: sparse regression (orthogonal "
                f"matching pursuit, coefficients in {result.unit}) of the residual on a generic "
                "library of standardised signals; "
                f"it explains {100 * hint.heldout_r2:.0f} % of the held-out residual "
                "variance",
            ),
        )
    if hint is not None and hint.periodic:
        text = f"\n\n**Hint (not an identified effect):** the {hint.periodic}."
    return tables, text


def _method_text(result: LoopResult) -> str:
    """How the loop decided: the base, the three roles of rows, the tests and the intervals;
    and what it cost."""
    return (
        f"Base: **{result.base_name}** as fitted by its family (the 'before'); for the tests its "
        "terms are refitted by least squares with every profiled parameter profiled, alone and "
        "with each candidate. Three roles of rows: candidates are fitted and tested on the "
        "training rows, selected by blocked cross-validation on those same rows (with a block "
        "bootstrap of the change in out-of-fold RMSE), and the before/after errors are "
        "**one-step** on the comparison's held-out rows, which no decision has seen (a lead's "
        "reach before each segment's end left out). Tests count the effective sample size "
        "n / τ_int (integrated autocorrelation time of the residual). Linear parameters' "
        "intervals are the OLS sandwich with the residual's autocovariance (calibrated for "
        f"residual correlation times up to {CALIBRATED_TAU:g} samples by "
        "benchmarks/bench_calibration_balance.py); a profiled parameter's is its profile "
        "likelihood's on n / τ_int, its ends interpolated where the likelihood ratio crosses its "
        "quantile, around the estimate refined between grid values (it always holds the "
        "estimate); an undefined standard error is left empty, never zero."
        + (f"\n\n{result.cost_text()}" if result.costs else "")
    )
