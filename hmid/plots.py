"""Figures for the comparison report: measured vs predicted balance, residuals (matplotlib, Agg)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pandas as pd


def new_figure(**kwargs):
    """A matplotlib Figure drawn with Agg (for the report and the studies' figures)."""
    # matplotlib's object-oriented Figure renders with Agg without touching pyplot's global
    # backend, so library plotting never changes a user's notebook backend.
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def _held_out_time(frame: pd.DataFrame) -> tuple[np.ndarray, list[tuple[float, str]]]:
    """One time axis over the held-out blocks of all logs, placed end to end."""
    t_axis, marks, offset = np.empty(len(frame)), [], 0.0
    for name, rows in frame.groupby("log", sort=False):
        t = rows["t"].to_numpy()
        t_axis[rows.index] = t - t[0] + offset
        marks.append((offset, str(name)))
        offset += t[-1] - t[0] + 0.2
    return t_axis, marks


def _stretches(frame: pd.DataFrame) -> np.ndarray:
    """Each row's stretch of consecutive held-out rows: a new one where the log changes or the
    time steps over excluded rows (more than 1.5 sampling intervals)."""
    t = frame["t"].to_numpy(float)
    log = frame["log"].astype(str).to_numpy()
    dt = np.diff(t)
    step = np.median(dt[dt > 0]) if np.any(dt > 0) else np.inf
    new = np.concatenate([[True], (log[1:] != log[:-1]) | (dt > 1.5 * step) | (dt < 0)])
    return np.cumsum(new)


def _gapped(keep: np.ndarray, stretch: np.ndarray, *columns: np.ndarray) -> list[np.ndarray]:
    """The ``keep`` rows of each column with NaN between rows of different stretches, so a line
    never bridges excluded rows."""
    cut = np.flatnonzero(np.diff(stretch[keep]) != 0) + 1
    return [np.insert(c[keep].astype(float), cut, np.nan) for c in columns]


#: points per time-series panel: a figure 11 inches wide shows no more (min and max per bin
#: keep every peak, so a decimated trace looks like the full one)
PANEL_POINTS = 4000


def envelope(values: np.ndarray, points: int = PANEL_POINTS) -> np.ndarray:
    """Sorted row indices that keep the minimum and maximum of ``values`` in each of at most
    ``points // 2`` consecutive bins of equal length (all rows when there are fewer)."""
    n = len(values)
    if n <= points:
        return np.arange(n)
    width = -(-n // (points // 2))
    bins = -(-n // width)
    # the last bin is padded with its own last value: an index there never passes the end
    padded = np.concatenate([values, np.full(bins * width - n, values[-1])]).reshape(bins, width)
    start = width * np.arange(bins)
    found = np.concatenate([start + padded.argmin(axis=1), start + padded.argmax(axis=1)])
    return np.unique(np.minimum(found, n - 1))


def plot_model(
    predictions: pd.DataFrame, model: str, path: Path, label: str = "F_m", unit: str = "N"
) -> None:
    """Four panels for one model on held-out data: the measured quantity it explains (``label``,
    known terms subtracted) over time (cf. thesis Fig. 4.4), residual over time, residual
    histogram, predicted vs measured. Time series are drawn from their min-max envelope
    (:func:`envelope`); the histogram uses every row."""
    frame = predictions.reset_index(drop=True)
    y, y_hat = frame["target"].to_numpy(), frame[model].to_numpy()
    residual = y - y_hat
    t_axis, marks = _held_out_time(frame)
    stretch = _stretches(frame)
    keep = np.union1d(envelope(y), envelope(y_hat))
    fig = new_figure(figsize=(11, 6.5))
    grid = fig.add_gridspec(2, 3)
    ax = fig.add_subplot(grid[0, :])
    ax.plot(t_axis[keep], y[keep], ".", ms=1.5, color="0.55", label=f"measured {label}")
    ax.plot(*_gapped(keep, stretch, t_axis, y_hat), "-", lw=0.8, color="C0",
            label=f"{model} (one-step)")  # fmt: skip
    for start, name in marks:
        ax.axvline(start, color="0.8", lw=0.8)
        ax.text(start, ax.get_ylim()[1], f" {name}", va="top", fontsize=7, color="0.4")
    # a long name (a knee rig's "inertial force of the load, ...") on lines that fit the panel
    ylabel = "\n".join(textwrap.wrap(f"{label} [{unit}]", 32))
    ax.set(xlabel="held-out time, logs end to end [s]", ylabel=ylabel)
    ax.legend(loc="lower right", fontsize=8)
    ax = fig.add_subplot(grid[1, 0])
    rows = envelope(residual)
    if f"{model} lower" in frame:  # the band around the prediction: visible at the residual's
        # scale, where at the measured quantity's it is thinner than the line
        lower = frame[f"{model} lower"].to_numpy() - y_hat
        upper = frame[f"{model} upper"].to_numpy() - y_hat
        band = np.union1d(envelope(lower), envelope(upper))
        ax.fill_between(*_gapped(band, stretch, t_axis, lower, upper), color="C0", alpha=0.35,
                        lw=0, label="predictive band − prediction")  # fmt: skip
        ax.legend(loc="lower right", fontsize=7)
    ax.plot(t_axis[rows], residual[rows], ".", ms=1, color="C3")
    ax.axhline(0, color="k", lw=0.6)
    ax.set(xlabel="held-out time [s]", ylabel=f"residual [{unit}]")
    ax = fig.add_subplot(grid[1, 1])
    ax.hist(residual, bins=60, color="C3", alpha=0.8)
    ax.set(xlabel=f"residual [{unit}]", ylabel="samples")
    ax = fig.add_subplot(grid[1, 2])
    ax.plot(y[keep], y_hat[keep], ".", ms=1, alpha=0.5)  # the extremes and a spread between
    lims = [min(y.min(), y_hat.min()), max(y.max(), y_hat.max())]
    ax.plot(lims, lims, "k-", lw=0.6)
    ax.set(xlabel=f"measured [{unit}]", ylabel=f"predicted [{unit}]")
    fig.suptitle(f"{model}: held-out data", fontsize=11)
    # fixed margins: tight_layout lays the figure out twice, a third of its cost, and every
    # model's figure has the same panels
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.08, top=0.92, hspace=0.32, wspace=0.28)
    fig.savefig(path, dpi=90, format="png")


def plot_scores(scores: pd.DataFrame, path: Path, unit: str = "N") -> None:
    """Held-out RMSE and NRMSE fit of every model, side by side."""
    fig = new_figure(figsize=(10, 0.32 * len(scores) + 1.3))
    axes = fig.subplots(1, 2)
    names = scores["model"][::-1]
    axes[0].barh(names, scores["rmse (held-out)"][::-1], color="C0")
    axes[0].set_xlabel(f"held-out RMSE [{unit}] (one-step)")
    axes[1].barh(names, scores["nrmse_fit_pct (held-out)"][::-1], color="C2")
    axes[1].set_xlabel("held-out NRMSE fit [%]")
    axes[1].set_yticklabels([])
    fig.tight_layout()
    fig.savefig(path, dpi=90, format="png")
