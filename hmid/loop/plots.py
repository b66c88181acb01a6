"""Figures of the loop: residual diagnostics before and after the added effects."""

from __future__ import annotations

from pathlib import Path

from hmid.loop.diagnostics import MIN_DIAGNOSED_ROWS, SPECTRUM_ROWS, binned_mean, signals, unit
from hmid.loop.result import LoopResult


def _figure(**kwargs):
    from matplotlib.figure import Figure  # object-oriented: never touches pyplot's backend

    return Figure(**kwargs)


def _empty(ax, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", fontsize=7, transform=ax.transAxes)


def plot_whiteness(result: LoopResult, path: Path) -> None:
    """Autocorrelation with the 99 % white-noise bound, cross-correlation with the inputs, and
    the residual spectrum, before and after."""
    fig = _figure(figsize=(11, 6.5))
    # fixed margins: the panels and their labels are the same for every run, and a constrained
    # layout was two thirds of the figure's cost
    fig.subplots_adjust(left=0.07, right=0.985, bottom=0.08, top=0.95, hspace=0.42, wspace=0.3)
    axes = fig.subplots(2, 3)
    for row, (label, d) in enumerate(
        (("before", result.diagnostics_before), ("after", result.diagnostics_after))
    ):
        ax = axes[row, 0]
        ax.plot(d.lags_s, d.acf, lw=1)
        ax.axhspan(-d.acf_bound, d.acf_bound, color="0.85", label="99 % bound (white)")
        ax.set(xlabel="lag [s]", ylabel="autocorrelation", title=f"residual ACF, {label}")
        ax.legend(fontsize=7)
        ax = axes[row, 1]
        for name in d.ccf.columns:
            ax.plot(d.ccf.index, d.ccf[name], lw=1, label=name)
        ax.axhspan(-d.acf_bound, d.acf_bound, color="0.85")
        ax.set(xlabel="lag [s]", ylabel="correlation", title=f"residual vs inputs, {label}")
        ax.legend(fontsize=7)
        ax = axes[row, 2]
        freq, psd = d.spectrum
        ax.set(xlabel="frequency [Hz]", ylabel=f"PSD [({result.unit})²/Hz]",
               title=f"residual spectrum, {label}")  # fmt: skip
        if len(freq) > 2:
            ax.semilogy(freq[1:], psd[1:], lw=1)
        else:  # an empty panel says why in its place
            _empty(ax, f"no spectrum: it needs {SPECTRUM_ROWS:,} consecutive usable training "
                   "rows,\nand no run of them is as long here (motion stops and reversals\n"
                   "cut the logs)")  # fmt: skip
    fig.savefig(path, dpi=110)


def plot_pattern(result: LoopResult, path: Path) -> None:
    """Residual mean per bin of the signal that explained most of it (before) and the one
    that explains most of what remains (after), per direction of motion."""
    fig = _figure(figsize=(11, 4))
    fig.subplots_adjust(left=0.07, right=0.985, bottom=0.13, top=0.91, wspace=0.2)
    axes = fig.subplots(1, 2)
    data = result.data
    if data is None:
        raise ValueError("plot_pattern needs the loop result's data (the rows analysed)")
    values = signals(data)
    rows = data.train
    for ax, label, d, residual in (
        (axes[0], "before", result.diagnostics_before, result.residual_before),
        (axes[1], "after", result.diagnostics_after, result.residual_after),
    ):
        name, eta2 = d.strongest
        if name not in values:  # too few finite rows: said in the panel's place
            _empty(
                ax,
                f"{label}: no pattern scan (fewer than {MIN_DIAGNOSED_ROWS} finite residual rows)",
            )
            continue
        table = binned_mean(residual, rows, values[name], data)
        for direction, part in table.groupby("direction"):
            ax.plot(part["centre"], part["mean"], "o-", ms=3, lw=1, label=direction)
        ax.axhline(0, color="0.6", lw=0.8)
        ax.set(
            xlabel=f"{name} [{unit(data, name)}]",
            ylabel=f"mean residual [{result.unit}]",
            title=f"{label}: strongest dependence on {name} (η² = {eta2:.3f})",
        )
        ax.legend(fontsize=7)
    fig.savefig(path, dpi=110)
