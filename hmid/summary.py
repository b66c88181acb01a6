"""A descriptive summary of denoised logs: span, sampling, channel ranges, motion, findings.

This is the first thing to read about a data set before identifying anything: it shows at a
glance whether the logs cover the operating range and whether the loader flagged problems.
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from hmid.io.log import Log


@dataclass(frozen=True)
class LogSummary:
    """Key numbers of one log (SI units): ``ranges`` maps each channel to (min, max)."""

    name: str
    role: str
    pieces: int
    samples: int
    duration_s: float
    rate_hz: float
    worst_gap_s: float
    ranges: dict[str, tuple[float, float]]
    peak_speed: float | None
    peak_accel: float | None
    at_rest_fraction: float | None  # share of samples with |v| below 1 mm/s (1e-3 SI units/s)
    flags: tuple[str, ...]

    def as_dict(self) -> dict:
        return asdict(self)

    def row(self, units: dict[str, str]) -> dict:
        """A flat table row: ranges as 'min … max [unit]' columns."""
        out = {k: v for k, v in self.as_dict().items() if k not in ("ranges", "flags")}
        for channel, (lo, hi) in self.ranges.items():
            out[f"{channel} [{units.get(channel, '')}]"] = f"{lo:.4g} … {hi:.4g}"
        return out


def summarize(name: str, role: str, pieces: list[Log] | tuple[Log, ...], channels) -> LogSummary:
    """Summary of a log's pieces that went through :func:`hmid.denoise.denoise_log`."""
    # reduced piece by piece: a long log's channels are never copied into one array
    present = [c for c in channels if all(c in p for p in pieces)]
    moving = all("v" in p for p in pieces)
    accel = all("a_est" in p for p in pieces)
    samples = sum(len(p) for p in pieces)
    gaps = [float(np.max(np.diff(p.t))) for p in pieces if len(p) > 1]
    gaps += [float(b.t[0] - a.t[-1]) for a, b in itertools.pairwise(pieces)]
    return LogSummary(
        name=name,
        role=role,
        pieces=len(pieces),
        samples=samples,
        duration_s=float(sum(p.duration for p in pieces)),
        rate_hz=float(np.median([p.sample_rate for p in pieces])),
        worst_gap_s=max(gaps) if samples > 1 else 0.0,
        ranges={
            c: (min(float(np.min(p[c])) for p in pieces), max(float(np.max(p[c])) for p in pieces))
            for c in present
        },
        peak_speed=_peak(pieces, "v") if moving else None,
        peak_accel=_peak(pieces, "a_est") if accel else None,
        at_rest_fraction=(
            sum(int(np.count_nonzero(np.abs(p["v"]) < 1e-3)) for p in pieces) / samples
            if moving
            else None
        ),
        flags=tuple(f for p in pieces[:1] for f in p.flags),
    )


def _peak(pieces, channel: str) -> float:
    """max |channel| over the pieces, without an array of absolute values."""
    return max(max(float(np.max(p[channel])), -float(np.min(p[channel]))) for p in pieces)


def markdown(summaries: list[LogSummary], units: dict[str, str], title: str) -> str:
    """The summary as a Markdown report."""
    import pandas as pd

    from hmid.report.markdown import markdown_table

    table = pd.DataFrame([s.row(units) for s in summaries])
    lines = [
        f"# {title}",
        "",
        "Logs as loaded (SI, validated, channels in the rig's sign convention), smoothed by the "
        "configured moving average; velocity and acceleration estimated from the position by "
        "the configured differentiator.",
        "",
        markdown_table(table),
    ]
    flagged = [(s.name, f) for s in summaries for f in s.flags]
    lines += ["", "## Findings from validation", ""]
    lines += [f"- {name}: {flag}" for name, flag in flagged] or ["- none: no channel at its rails"]
    return "\n".join(lines) + "\n"


def plot_overview(logs: dict[str, list[Log]], channels: list[str], path: Path) -> None:
    """Each channel (raw grey, smoothed in colour) against time, one column per log."""
    from matplotlib.figure import Figure  # object-oriented: no global backend switch

    rows = [*channels, "v"]
    fig = Figure(figsize=(3.2 * len(logs), 2 * len(rows)))
    axes = fig.subplots(len(rows), len(logs), squeeze=False)
    for j, (name, pieces) in enumerate(logs.items()):
        axes[0, j].set_title(name, fontsize=9)
        for i, channel in enumerate(rows):
            ax = axes[i, j]
            for piece in pieces:
                if channel in piece:
                    ax.plot(piece.t, piece[channel], lw=0.5, color="0.6")
                    if f"{channel}_s" in piece:
                        ax.plot(piece.t, piece[f"{channel}_s"], lw=0.8, color="C0")
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_ylabel(channel)
        axes[-1, j].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
