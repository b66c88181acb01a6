"""Diagnostics of an MCMC run (trace and corner plots) and of a fit's residuals (lag-1 test).

Plots use Matplotlib's object-oriented API only (a :class:`~matplotlib.figure.Figure` per plot,
no pyplot state) and are written atomically; the format follows the path's suffix.

:func:`lag1_autocorrelation` tests whether residuals are serially correlated, which decides
whether to offer the AR(1) noise model: with ``r`` the residuals minus their mean,
``rho = sum(r[t] r[t+1]) / sum(r[t]^2)`` and the Ljung-Box statistic at lag 1,
``Q = n (n + 2) rho^2 / (n - 1)``, is chi-squared with one degree of freedom under white noise
(the same numbers as ``statsmodels.stats.diagnostic.acorr_ljungbox(r, lags=[1])``). With many
samples even a negligible ``rho`` is significant, hence the optional ``min_abs_rho``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from scipy import stats

from hmid.errors import ConfigError, SignalError
from hmid.files import atomic_path
from hmid.models.sls.sampler import SamplerResult

__all__ = [
    "corner_plot",
    "grid_plot",
    "lag1_autocorrelation",
    "physical_corner_plot",
    "residuals_correlated",
    "trace_plot",
]

_MAX_POINTS = 4000  # steps drawn per walker in a trace plot (longer chains are strided)


def trace_plot(result: SamplerResult, path: str | Path, names: Sequence[str] | None = None) -> Path:
    """One panel per parameter (and one for the log-probability), every walker, burn-in shaded."""
    names = list(result.names if names is None else names)
    unknown = [name for name in names if name not in result.names]
    if unknown or not names:
        raise ConfigError(
            f"trace_plot: unknown parameter(s) {unknown or names}; choose from {result.names}"
        )
    stride = max(1, result.n_steps // _MAX_POINTS)
    steps = np.arange(result.n_steps)[::stride] + 1
    alpha = min(0.6, 8.0 / result.n_walkers)
    fig = Figure(figsize=(8.0, 1.5 * (len(names) + 1) + 0.6), layout="constrained")
    axes = fig.subplots(len(names) + 1, 1, sharex=True, squeeze=False)[:, 0]
    series = [result.walkers[::stride, :, result.names.index(name)] for name in names]
    series.append(_log_prob(result, stride))
    for ax, label, values in zip(axes, [*names, "log prob"], series, strict=True):
        ax.plot(steps, values, color="C0", alpha=alpha, lw=0.5)
        ax.axvspan(0, result.burn_in, color="C3", alpha=0.12, lw=0)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("step")
    axes[0].set_title(
        f"{result.n_walkers} walkers, {result.n_steps} steps ({result.stop_reason}); burn-in "
        f"{result.burn_in} steps shaded; tau max {np.max(result.tau):.1f}",
        fontsize="medium",
    )
    return _save(fig, path)


def _log_prob(result: SamplerResult, stride: int) -> np.ndarray:
    """The walkers' log-probability, clipped below so the early climb does not hide the rest."""
    values = result.walkers_log_prob[::stride]
    kept = result.walkers_log_prob[result.burn_in :]
    low, high = np.quantile(kept, 0.001), np.max(kept)
    return np.maximum(values, low - 0.5 * (high - low))


def corner_plot(
    result: SamplerResult,
    path: str | Path,
    labels: Sequence[str] | None = None,
    truths: Sequence[float] | None = None,
) -> Path:
    """Pairwise and marginal histograms of the thinned posterior draws (the ``corner`` package),
    with the 5 %, 50 % and 95 % quantiles marked; ``truths`` (e.g. simulator values) overlaid."""
    import corner  # imports pyplot; kept out of hmid's import time

    dim = len(result.names)
    labels = list(result.names if labels is None else labels)
    if len(labels) != dim or (truths is not None and len(truths) != dim):
        raise ConfigError(f"corner_plot: need {dim} labels (and truths), one per {result.names}")
    if len(result.chain) <= dim:
        raise ConfigError(
            f"corner_plot: {len(result.chain)} posterior draws are too few for {dim} parameters"
        )
    fig = Figure(figsize=(2.0 * dim + 1.0, 2.0 * dim + 1.0))
    root = logging.getLogger()
    quiet = _Without("Too few points to create valid contours")
    root.addFilter(quiet)  # corner logs it for tight pairs, whose scatter still shows them
    try:
        corner.corner(
            result.chain,
            labels=labels,
            truths=truths,
            quantiles=[0.05, 0.5, 0.95],
            show_titles=True,
            title_fmt=".3g",
            fig=fig,
        )
    finally:
        root.removeFilter(quiet)
    return _save(fig, path, dpi=100)  # 15 inches square: 1,500 pixels are ample


#: Draws shown in a physical corner plot (a thinned subset: the shape is the same, the cost not).
CORNER_DRAWS = 4000


def physical_corner_plot(
    draws: dict[str, np.ndarray],
    units: dict[str, str],
    path: str | Path,
    truths: dict | None = None,
) -> Path:
    """The posterior's pairwise and marginal histograms in physical units (``draws``: name ->
    values), each axis labelled with its unit, the 5/50/95 % quantiles marked and a known truth
    drawn where there is one: ``truths`` is a simulator's rig (nested sections of numbers), read
    from the section that names most of the parameters. Titles are kept short and the
    ticks few, so that panels do not run into each other."""
    import corner  # imports pyplot; kept out of hmid's import time

    names = list(draws)
    chain = np.column_stack([np.asarray(draws[n], float).ravel() for n in names])
    if len(chain) > CORNER_DRAWS:
        chain = chain[np.linspace(0, len(chain) - 1, CORNER_DRAWS).astype(int)]
    if len(chain) <= len(names):
        raise ConfigError(
            f"corner_plot: {len(chain)} posterior draws are too few for {len(names)} parameters"
        )
    known = _truth_section(truths or {}, names)
    marks = [known.get(n) for n in names]
    labels = [f"{n} [{units[n]}]" if units.get(n) else n for n in names]
    dim = len(names)
    fig = Figure(figsize=(1.9 * dim + 1.2, 1.9 * dim + 1.2))
    root = logging.getLogger()
    quiet = _Without("Too few points to create valid contours")
    root.addFilter(quiet)
    try:
        corner.corner(
            chain,
            labels=labels,
            truths=marks if any(m is not None for m in marks) else None,
            truth_color="C3",
            quantiles=[0.05, 0.5, 0.95],
            show_titles=True,
            title_fmt=".4g",
            title_kwargs={"fontsize": 8},
            label_kwargs={"fontsize": 9},
            max_n_ticks=3,
            labelpad=0.12,
            fig=fig,
        )
    finally:
        root.removeFilter(quiet)
    for ax in fig.axes:
        ax.tick_params(labelsize=7)
        for axis in (ax.xaxis, ax.yaxis):
            formatter = axis.get_major_formatter()
            if hasattr(formatter, "set_powerlimits"):
                formatter.set_powerlimits((-3, 4))
            axis.get_offset_text().set_fontsize(7)
    if any(m is not None for m in marks):
        fig.text(0.98, 0.98, "red: the simulator's truth", ha="right", va="top", fontsize=10,
                 color="C3")  # fmt: skip
    fig.subplots_adjust(left=0.1, bottom=0.1, right=0.98, top=0.96, wspace=0.12, hspace=0.12)
    return _save(fig, path, dpi=90)


def _truth_section(tree: dict, names: list[str]) -> dict[str, float]:
    """The numbers of the section of ``tree`` (itself or a nested one) that names most of
    ``names`` (at least two), by name; empty if none does."""
    best: dict[str, float] = {}
    todo = [tree]
    while todo:
        section = todo.pop(0)
        numbers = {k: float(v) for k, v in section.items()
                   if isinstance(v, int | float) and not isinstance(v, bool)}  # fmt: skip
        if sum(n in numbers for n in names) > max(1, sum(n in best for n in names)):
            best = numbers
        todo += [v for v in section.values() if isinstance(v, dict)]
    return best


class _Without(logging.Filter):
    """Drops log records whose message starts with ``text``."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.text = text

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(self.text)


def lag1_autocorrelation(residual: np.ndarray) -> tuple[float, float]:
    """Lag-1 autocorrelation of ``residual`` and the Ljung-Box p-value of "no correlation"."""
    r = np.asarray(residual, dtype=float)
    if r.ndim != 1 or r.size < 3:
        raise SignalError(f"lag-1 test: need a 1-D residual of >= 3 values, got shape {r.shape}")
    bad = np.flatnonzero(~np.isfinite(r))
    if bad.size:
        raise SignalError(f"lag-1 test: residual row {bad[0]}: non-finite value {r[bad[0]]}")
    r = r - r.mean()
    denominator = float(np.dot(r, r))
    if denominator == 0:
        raise SignalError("lag-1 test: the residual is constant; its correlation is undefined")
    rho = float(np.dot(r[:-1], r[1:]) / denominator)
    n = r.size
    q = n * (n + 2) * rho**2 / (n - 1)
    return rho, float(stats.chi2.sf(q, df=1))


def residuals_correlated(
    residual: np.ndarray, alpha: float = 0.01, min_abs_rho: float = 0.0
) -> bool:
    """Whether the lag-1 correlation is significant at level ``alpha`` (and ``|rho| >=
    min_abs_rho``): then an AR(1) noise model is worth offering."""
    if not 0 < alpha < 1:
        raise ConfigError(f"residuals_correlated: alpha must lie in (0, 1), got {alpha!r}")
    rho, p_value = lag1_autocorrelation(residual)
    return p_value < alpha and abs(rho) >= min_abs_rho


def grid_plot(grid, path: str | Path) -> Path:
    """The exact posterior's marginal densities on its grid: tau (and phi for AR(1) noise)."""
    axes = ["tau"] + (["phi"] if len(grid.atanh_phi) > 1 else [])
    fig = Figure(figsize=(4.5 * len(axes), 3.2))
    for i, axis in enumerate(axes):
        ax = fig.add_subplot(1, len(axes), i + 1)
        value, density = grid.marginal(axis)
        ax.plot(value, density, color="C0")
        per = "ln tau" if axis == "tau" else "atanh phi"
        ax.set(xlabel="tau [s]" if axis == "tau" else "phi", ylabel=f"density (per unit {per})")
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 3), useOffset=False)
    fig.suptitle("exact posterior on its grid", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def _save(fig: Figure, path: str | Path, dpi: int = 120) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=dpi)
    return path
