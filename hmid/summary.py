"""A descriptive summary of denoised logs: span, sampling, ranges, motion, findings.

This is the first thing to read about a data set before identifying anything: it shows at a
glance whether the logs cover the operating range and whether the loader flagged problems.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from hmid.io.log import Log


@dataclass(frozen=True)
class LogSummary:
    """Key numbers of one log (SI units except where the name says otherwise)."""

    name: str
    role: str
    samples: int
    duration_s: float
    rate_hz: float
    worst_gap_s: float
    P_kPa: tuple[float, float] | None
    x_mm: tuple[float, float] | None
    F_N: tuple[float, float] | None
    peak_speed_m_s: float | None
    peak_accel_m_s2: float | None
    at_rest_fraction: float | None  # share of samples with |v| below 1 mm/s
    flags: tuple[str, ...]

    def as_dict(self) -> dict:
        return asdict(self)


def _span(log: Log, channel: str, scale: float) -> tuple[float, float] | None:
    if channel not in log:
        return None
    y = log[channel] * scale
    return (float(np.min(y)), float(np.max(y)))


def summarize(name: str, role: str, log: Log) -> LogSummary:
    """Summary of a log that went through :func:`hmid.denoise.denoise_log`."""
    v = log["v"] if "v" in log else None
    a = log["a_est"] if "a_est" in log else None
    return LogSummary(
        name=name,
        role=role,
        samples=len(log),
        duration_s=log.duration,
        rate_hz=log.sample_rate,
        worst_gap_s=float(np.max(np.diff(log.t))),
        P_kPa=_span(log, "P", 1e-3),
        x_mm=_span(log, "x", 1e3),
        F_N=_span(log, "F", 1.0),
        peak_speed_m_s=None if v is None else float(np.max(np.abs(v))),
        peak_accel_m_s2=None if a is None else float(np.max(np.abs(a))),
        at_rest_fraction=None if v is None else float(np.mean(np.abs(v) < 1e-3)),
        flags=log.flags,
    )


def _fmt(span: tuple[float, float] | None, digits: int = 2) -> str:
    return "—" if span is None else f"{span[0]:.{digits}f} … {span[1]:.{digits}f}"


def markdown(summaries: list[LogSummary], title: str) -> str:
    """The summary as a Markdown report."""
    lines = [
        f"# {title}",
        "",
        "Logs as loaded (SI, validated), smoothed by the configured moving average; velocity "
        "and acceleration estimated from x by the configured differentiator.",
        "",
        "| log | role | samples | duration [s] | rate [Hz] | worst gap [ms] | P [kPa] | x [mm] "
        "| F [N] | peak speed [mm/s] | peak accel. [m/s²] | at rest |",
        "|---|---|---:|---:|---:|---:|---|---|---|---:|---:|---:|",
    ]
    for s in summaries:
        speed = "—" if s.peak_speed_m_s is None else f"{s.peak_speed_m_s * 1e3:.1f}"
        accel = "—" if s.peak_accel_m_s2 is None else f"{s.peak_accel_m_s2:.2f}"
        rest = "—" if s.at_rest_fraction is None else f"{s.at_rest_fraction:.0%}"
        lines.append(
            f"| {s.name} | {s.role} | {s.samples} | {s.duration_s:.3f} | {s.rate_hz:.1f} "
            f"| {s.worst_gap_s * 1e3:.1f} | {_fmt(s.P_kPa, 1)} | {_fmt(s.x_mm)} | {_fmt(s.F_N)} "
            f"| {speed} | {accel} | {rest} |"
        )
    flagged = [(s.name, f) for s in summaries for f in s.flags]
    lines += ["", "## Findings from validation", ""]
    lines += [f"- {name}: {flag}" for name, flag in flagged] or ["- none: no channel at its rails"]
    return "\n".join(lines) + "\n"


def plot_overview(logs: dict[str, Log], path: Path) -> None:
    """P, x, v and F against time for each log, one column per log."""
    from matplotlib.figure import Figure  # object-oriented: no global backend switch

    rows = [
        ("P", 1e-3, "P [kPa]"),
        ("x", 1e3, "x [mm]"),
        ("v", 1e3, "v [mm/s]"),
        ("F", 1.0, "F [N]"),
    ]
    fig = Figure(figsize=(3.2 * len(logs), 8))
    axes = fig.subplots(len(rows), len(logs), squeeze=False)
    for j, (name, log) in enumerate(logs.items()):
        axes[0, j].set_title(name, fontsize=9)
        for i, (channel, scale, label) in enumerate(rows):
            ax = axes[i, j]
            if channel in log:
                ax.plot(log.t, log[channel] * scale, lw=0.5, color="0.6")
                if f"{channel}_s" in log:
                    ax.plot(log.t, log[f"{channel}_s"] * scale, lw=0.8)
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_ylabel(label)
        axes[-1, j].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
