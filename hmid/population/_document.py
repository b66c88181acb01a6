"""The population report: what was fitted, how well the law holds, and leave-one-out."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from hmid.population._model import PopulationFit
from hmid.report import Figure, Report, Section, Table


def population_report(
    fit: PopulationFit,
    muscles: pd.DataFrame,
    exponents: pd.DataFrame,
    forces: pd.DataFrame | None,
    params: pd.DataFrame | None,
    metrics: dict,
    figure: Path,
    provenance: dict,
) -> Report:
    """The report: the summary lines, the law, the muscles, the diagnostics and, where it ran,
    leave-one-out."""
    sections = [
        _law_section(exponents, figure),
        _muscles_section(muscles),
        _diagnostics_section(fit),
    ]
    if forces is not None:
        sections.append(_leave_one_out_section(forces, params))
    return Report(
        title="Population: a generic Hydro Muscle model",
        summary=tuple(_summary(fit, metrics)),
        sections=tuple(sections),
        provenance=provenance,
    )


def _summary(fit: PopulationFit, metrics: dict) -> list[tuple[str, str]]:
    """The summary lines: the fit's targets, then leave-one-out's where it ran."""
    verdict = "converged" if metrics["converged"] else "NOT converged"
    summary = [
        ("muscles", str(len(fit.names))),
        (
            "exponents within their 90 % interval",
            f"{metrics['exponents_within_interval']} of {metrics['exponents']}",
        ),
        (
            "NUTS diagnostics",
            f"R-hat max {metrics['r_hat_max']:.3f}, bulk ESS min "
            f"{metrics['ess_bulk_min']:.0f} ({verdict})",
        ),
        ("population fit", f"{fit.wall_s:.1f} s wall, {fit.cpu_s:.1f} s CPU (target ≤ 60 s)"),
    ]
    if "loo_median_specs_over_own" in metrics:
        summary += [
            (
                "left-out force RMSE / own model (median)",
                f"{metrics['loo_median_specs_over_own']:.2f} (target ≤ 2)",
            ),
            (
                "left-out force RMSE / one other muscle's model (median)",
                f"{metrics['loo_median_specs_over_one_other']:.3f} (target ≤ 0.3)",
            ),
        ]
    if "loo_coverage" in metrics:
        summary.append(
            (
                "90 % predictive intervals' coverage (left-out parameters)",
                f"{metrics['loo_coverage']:.2f} over {metrics['loo_intervals']} "
                "(target 0.87–0.93; the benchmark replicates the population)",
            )
        )
    return summary


def _law_section(exponents: pd.DataFrame, figure: Path) -> Section:
    return Section(
        "The scaling law",
        "log p = c + Σ e·log(spec) per parameter; exponents with priors centred on the "
        "physically expected values (A_eff ~ bore area, F0 ~ wall area, k1 ~ k2 ~ E A_w/L, "
        "k3 ~ E A_w/L³, tau constant), each muscle's SLS posterior carried in as a "
        "multivariate normal likelihood. NumPyro NUTS; ArviZ diagnostics below.",
        tables=(
            Table(
                exponents,
                "Exponents: posterior median and 90 % interval beside the expected value",
                key_columns=("parameter", "specification"),
            ),
        ),
        figures=(
            Figure(
                figure,
                "Each parameter against each specification: the muscles' parameters in "
                "the population fit (the other specifications' part of the law taken "
                "out) and the law's line.",
            ),
        ),
    )


def _muscles_section(muscles: pd.DataFrame) -> Section:
    return Section(
        "The muscles",
        "Builds, each muscle's own SLS fit (posterior mean) and the simulator's truth.",
        tables=(Table(muscles, "Muscles", key_columns=("muscle",)),),
    )


def _diagnostics_section(fit: PopulationFit) -> Section:
    return Section(
        "Diagnostics",
        "ArviZ summary of the law's coordinates.",
        tables=(
            Table(
                fit.diagnostics.reset_index(names="coordinate"),
                "NUTS diagnostics",
                collapsed=True,
            ),
        ),
    )


def _leave_one_out_section(forces: pd.DataFrame, params: pd.DataFrame | None) -> Section:
    tables = [Table(forces, "Held-out force, left-out muscles", key_columns=("muscle",))]
    if params is not None:
        tables.append(
            Table(
                params,
                "Left-out parameters: predicted, 90 % predictive interval, truth",
                collapsed=True,
            )
        )
    return Section(
        "Leave one muscle out",
        "Each muscle predicted from its specifications by the population fitted without it; "
        "held-out force RMSE (the last 30 % of each dynamic log) against (a) its own fitted "
        "model, (b) the population's mean model without specifications, (c) one other "
        "muscle's model used as is (the thesis's way; median over the others), and (d) the "
        "simulator's exact law without the muscle's manufacturing scatter, the floor of "
        "any prediction from specifications alone.",
        tables=tuple(tables),
    )
