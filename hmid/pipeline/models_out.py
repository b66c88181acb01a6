"""The run folder's ``models/``: a model file per fitted model and the posterior draws of the
families that have them (ArviZ netCDF)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hmid.pipeline.stages import file_stem
from hmid.portable import write_model_file
from hmid.portable.posterior import write_posterior


def write_models(fitted, exported: dict, run_dir: Path) -> dict[str, str]:
    """Write ``models/<name>.json`` (and ``<name>.posterior.nc``) for every exported model; what
    each became, by model name: its file, relative to the run folder, or why there is none."""
    folder = Path(run_dir) / "models"
    folder.mkdir(exist_ok=True)
    out = {}
    for model in fitted:
        document = exported.get(model.name)
        if not isinstance(document, dict):
            out[model.name] = document or "not exported"
            continue
        if document.get("posterior"):
            draws = model.model.posterior_draws()
            attrs = {"model": model.name, "family": model.family, "method": model.interval.method
                     if model.interval else ""}  # fmt: skip
            write_posterior(draws, folder / document["posterior"], attrs)
        path = write_model_file(document, folder / f"{file_stem(model.name)}.json")
        out[model.name] = str(path.relative_to(run_dir))
    return out


def free_run_section(config, free_runs: dict, units, out, drawing):
    """The free runs' section (None without any) and their table (written as CSV)."""
    from hmid.report import Figure, Section, Table

    position = config.rig.position
    table = free_run_table(free_runs, units["target"], position)
    if not len(table):
        return None, table
    out.csv(table, "free_run_scores.csv")
    label = config.rig.explained.name
    figure = out.figures / "free_run.png"
    simulated = any(run.runs for run in free_runs.values())
    if simulated:
        drawing.submit(plot_free_runs, free_runs, figure, label, units["target"])
    bands = sorted({f"{r.band} ({100 * r.level:g} %)" for r in free_runs.values() if r.level})
    text = (
        f"Each model run **free** over the held-out blocks: {position} simulated from the "
        "measured inputs and the measured state at each block's start alone, as a controller "
        "uses the model (diffrax Tsit5, error-controlled; sign(v) regularised as tanh(v / v0), "
        "v0 as fine as one sample's step integrates stably). Fit % is MATLAB's NRMSE fit of the "
        "position. "
        + (f"Bands: {'; '.join(bands)}. The disturbance (a force or a drift) is chosen and "
           "scaled on the training blocks, to the level raised by what a left-out block misses "
           "(the training column); the band-coverage column, its coverage of the held-out "
           "position, is the check." if bands else "")
    )  # fmt: skip
    skipped = [f"{name}: {run.skipped}" for name, run in free_runs.items() if run.skipped]
    if skipped:
        text += "\n\n" + "\n".join(f"- {line}" for line in skipped)
    section = Section(
        "Free run on held-out data",
        text=text,
        tables=(
            Table(
                table,
                "Free-run scores per model (held-out blocks)",
                key_columns=_free_run_keys(table),
            ),
        ),
        figures=(
            Figure(
                figure,
                "Measured and simulated position, the longest held-out blocks",
                collapsed=True,
            ),
        )  # the answer above says the best model's free run
        if simulated
        else (),
    )
    return section, table


def _free_run_keys(table: pd.DataFrame) -> tuple[str, ...]:
    keep = ("model", "fit %", "rmse", "band coverage", "diverged", "note")
    return tuple(c for c in table.columns if c.startswith(keep) and "explained" not in c)


_NO = (np.nan, np.nan)  # no band, no interval of its coverage


def _level() -> str:
    from hmid.portable.freerun import COVERAGE_INTERVAL

    return f"{100 * COVERAGE_INTERVAL:g} %"


def free_run_table(free_runs: dict, unit: str, position: str | None) -> pd.DataFrame:
    """One row per model: the free run's scores beside what it simulated, or why it did not."""
    rows, level = [], _level()
    for name, run in free_runs.items():
        scores = run.scores() if run.runs else {}
        first = min((r.diverged_at for r in run.runs if r.diverged_at is not None), default=None)
        cal = run.calibration
        rows.append({
            "model": name,
            "free-run blocks": scores.get("free-run blocks", 0),
            f"fit % ({position})": scores.get("fit % (x)", np.nan),
            f"rmse {position} [mm]": 1e3 * scores.get("rmse x", np.nan),
            f"rmse explained [{unit}]": scores.get("rmse explained", np.nan),
            f"band coverage ({100 * run.level:g} %)" if run.level else "band coverage": scores.get(
                "band coverage", np.nan),
            f"band coverage, {level} interval low": scores.get("band coverage interval", _NO)[0],
            f"band coverage, {level} interval high": scores.get("band coverage interval", _NO)[1],
            "band coverage (training)": np.nan if cal is None else cal.coverage,
            "disturbance": "" if cal is None else cal.kind,
            "disturbance scale": cal.scale if cal is not None and cal.reachable else np.nan,
            "cross-calibrated miss": np.nan if cal is None else cal.miss,
            "diverged": scores.get("diverged", 0),
            "first divergence [s]": np.nan if first is None else first,
            "note": run.skipped or "; ".join(sorted({r.reason for r in run.runs if r.reason} | (
                {run.note} if run.note else set()) | (
                {cal.why_not()} if cal is not None and not cal.reachable else set()))),
        })  # fmt: skip
    return pd.DataFrame(rows)


def plot_free_runs(free_runs: dict, path: Path, label: str, unit: str) -> Path:
    """Measured and simulated position, every model, one panel per held-out block (the three
    longest)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [r for r in free_runs.values() if r.runs]
    if not runs:
        return path
    order = sorted(range(len(runs[0].runs)), key=lambda i: -len(runs[0].runs[i].t))[:3]
    fig, axes = plt.subplots(len(order), 1, figsize=(9, 2.2 * len(order)), squeeze=False)
    for ax, i in zip(axes[:, 0], order, strict=True):
        block = runs[0].runs[i]
        ax.plot(block.t, 1e3 * block.x_measured, color="black", lw=1.4, label="measured")
        # the measured range with a margin: a model that leaves it (and its band) is cut
        # off at the edge rather than squashing the others into a line
        low, high = np.nanmin(1e3 * block.x_measured), np.nanmax(1e3 * block.x_measured)
        margin = 0.25 * (high - low) or 1.0
        for run in runs:
            sim = run.runs[i]
            (line,) = ax.plot(sim.t, 1e3 * sim.x_simulated, lw=0.9, label=run.model)
            if sim.band is not None:
                lower, upper = (1e3 * b for b in sim.band)
                ax.fill_between(sim.t, lower, upper, color=line.get_color(), alpha=0.25, lw=0)
        ax.set_ylim(low - margin, high + margin)
        ax.set_ylabel("position [mm]")
        ax.set_title(f"{block.log}: free run from {block.t[0]:.2f} s", fontsize=9)
    axes[-1, 0].set_xlabel("t [s]")
    axes[0, 0].legend(fontsize=7, ncol=4, loc="upper right")
    fig.subplots_adjust(left=0.08, right=0.98, top=0.95, bottom=0.08, hspace=0.35)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
