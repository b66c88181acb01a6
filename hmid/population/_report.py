"""The population's tables, figure, metrics and report (pure functions of the results)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hmid.population._law import EXPECTED, FEATURES, PARAMETERS, UNITS, feature_matrix, offsets
from hmid.population._model import PopulationFit


def exponent_table(fit: PopulationFit, interval: float) -> pd.DataFrame:
    """Each exponent: posterior median, interval, the physically expected value, and whether
    the interval holds it."""
    lo_q, hi_q = (1 - interval) / 2, (1 + interval) / 2
    rows = []
    for k, p in enumerate(PARAMETERS):
        for j, f in enumerate(FEATURES):
            draws = fit.exponent[:, k, j]
            lo, hi = float(np.quantile(draws, lo_q)), float(np.quantile(draws, hi_q))
            expected = EXPECTED[p][j]
            rows.append(
                {
                    "parameter": p,
                    "specification": f,
                    "exponent": float(np.median(draws)),
                    "lower": lo,
                    "upper": hi,
                    "expected": expected,
                    "within": bool(lo <= expected <= hi),
                }
            )
    return pd.DataFrame(rows)


def muscle_table(fit: PopulationFit, fits, truths) -> pd.DataFrame:
    """Each muscle: its build, its own fit (mean) and the truth where known."""
    rows = []
    for i, (spec, own) in enumerate(zip(fit.specs, fits, strict=True)):
        row = {
            "muscle": own.name,
            "length [m]": spec.length,
            "bore [m]": spec.inner_diameter,
            "outer [m]": spec.outer_diameter,
        }
        for k, p in enumerate(PARAMETERS):
            row[f"{p} [{UNITS[p]}]"] = float(own.mean[k])
            if truths[i] is not None:
                row[f"{p} truth"] = float(truths[i][k])
        rows.append(row)
    return pd.DataFrame(rows)


def law_figure(fit: PopulationFit, fits, path: Path) -> Path:
    """Each parameter against each specification, with the law: the muscles' parameters with the
    other specifications' part of the law taken out (partial residuals), and the law's line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    F = feature_matrix(fit.specs) - fit.center
    Off = np.array([offsets(s) for s in fit.specs]) - fit.center_offsets
    c = np.median(fit.intercept, axis=0)
    e = np.median(fit.exponent, axis=0)
    # each muscle's parameters as the population fit holds them (its own fit, shrunk where it
    # says little: a long muscle's k3 can be negative on its own)
    means = np.median(fit.muscles, axis=0) / fit.scale
    fig, axes = plt.subplots(len(PARAMETERS), len(FEATURES), figsize=(10, 14), squeeze=False)
    for k, p in enumerate(PARAMETERS):
        logy = np.log(np.maximum(means[:, k], 1e-12))
        for j, name in enumerate(FEATURES):
            ax = axes[k, j]
            others = F @ e[k] - F[:, j] * e[k, j] + Off[:, k]
            ax.plot(F[:, j] + fit.center[j], logy - others, "o", ms=4)
            grid = np.linspace(F[:, j].min(), F[:, j].max(), 20)
            ax.plot(
                grid + fit.center[j],
                c[k] + e[k, j] * grid,
                "-",
                label=f"exponent {e[k, j]:.2f} (expected {EXPECTED[p][j]:g})",
            )
            ax.set_xlabel(f"log {name}")
            ax.set_ylabel(f"log {p} (partial)")
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def targets(fit: PopulationFit, exponents: pd.DataFrame, forces, params) -> dict:
    """The issue's targets, measured (the fit's wall time goes to timings.json)."""
    out: dict = {
        "exponents_within_interval": int(exponents["within"].sum()),
        "exponents": len(exponents),
        "r_hat_max": float(fit.diagnostics["r_hat"].max()),
        "ess_bulk_min": float(fit.diagnostics["ess_bulk"].min()),
        "converged": fit.converged,
    }
    if forces is not None and "specs / own" in forces:
        out["loo_median_specs_over_own"] = float(forces["specs / own"].median())
        out["loo_median_specs_over_one_other"] = float(forces["specs / one other"].median())
        if "exact law, no scatter RMSE [N]" in forces:
            floor = forces["from specs RMSE [N]"] / forces["exact law, no scatter RMSE [N]"]
            out["loo_median_specs_over_exact_law"] = float(floor.median())
        out["targets"] = {
            "specs_over_own_max": 2.0,
            "specs_over_one_other_max": 0.3,
            "coverage": [0.87, 0.93],
        }
    if params is not None and params["covered"].notna().any():
        covered = params["covered"].dropna().astype(bool)
        out["loo_coverage"] = float(covered.mean())
        out["loo_intervals"] = len(covered)
    return out
