"""Free-fall figure: measured x(t), the model fitted on the sliding segment, and residuals."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from hmid.errors import LogError
from hmid.friction._estimate import FrictionEstimate
from hmid.io.log import Log


def plot_free_fall(
    logs: Sequence[Log], estimate: FrictionEstimate, path: str | Path, position: str = "x"
) -> Path:
    """Write the figure to ``path`` (format from its suffix) and return the path.

    Top: each log's measured x (dots) and its own fitted model over the sliding segment (line).
    Bottom: the x residuals on the segment, in mm. Logs are matched to fits by ``log.source``.
    """
    from matplotlib.figure import Figure  # object-oriented: no global backend switch

    # by file name: a cached estimate may have read the same files from another working folder
    fits = {Path(r.source).name: r for r in estimate.per_log}
    fig = Figure(figsize=(7, 6))
    # fixed margins: the same two panels for every rig (a tight layout was half the cost)
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.09, top=0.94, hspace=0.08)
    ax_x, ax_r = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    for k, log in enumerate(logs):
        if Path(log.source).name not in fits:
            raise LogError(f"{log.source}: not among the logs this friction estimate was fitted to")
        r = fits[Path(log.source).name]
        t, x = log.t, log[position]
        seg = (t >= r.t_start) & (t <= r.t_end)
        tau = t[seg] - r.t_ref
        u = estimate.model.travel(
            tau, r.direction * r.x_ref, r.direction * r.v_ref, r.params, estimate.rig
        )
        x_fit = r.direction * u
        colour = f"C{k % 10}"
        label = ", ".join(
            f"{p} = {r.params[p]:.3g} {estimate.units[p]}" for p in estimate.model.param_names
        )
        ax_x.plot(t, x * 1e3, ".", ms=2, color=colour, alpha=0.4)
        ax_x.plot(t[seg], x_fit * 1e3, "-", color=colour, label=f"{log.source}: {label}")
        ax_r.plot(t[seg], (x[seg] - x_fit) * 1e3, ".", ms=2, color=colour)
    ax_x.set_ylabel(f"{position} [mm]")
    ax_x.set_title(f"Free-fall friction fits ({estimate.model.name})")
    ax_x.legend(fontsize="small")
    ax_r.axhline(0.0, color="k", lw=0.8)
    ax_r.set_ylabel("residual [mm]")
    ax_r.set_xlabel("t [s]")
    path = Path(path)
    fig.savefig(path)
    return path
