"""What the SINDy family hands the pipeline: the force map for one-step scoring, the equation of
motion and its free run on held-out data, and the report's extra text, tables and figure."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.families.base import Extras, FigureSpec, FitData, FittedModel
from hmid.models.sindy._freerun import EquationOfMotion, FreeRunResult
from hmid.models.sindy._model import SINDyForceModel

VARIABLES = ("x", "v", "P")


def sequences(signals) -> dict[str, pd.DataFrame]:
    """Every segment of ``signals`` whole (t, x, v, P, target, train, validation), by name."""
    frame = signals.frame
    out = {}
    for rows in signals.segments():
        part = frame.iloc[rows]
        name = str(part["log"].iloc[0])
        key = name if name not in out else f"{name}#{int(part['segment'].iloc[0])}"
        columns = ["t", *VARIABLES, "target", "train", "validation"]
        out[key] = part[columns].rename(columns={"target": "F_m"}).reset_index(drop=True)
    return out


@dataclass(frozen=True)
class SINDyResult(FittedModel):
    """A fitted SINDy variant: ``force`` (one-step), ``eom`` and ``free_run`` (None if skipped).

    ``velocity`` re-estimates v of a whole log (``(t, x) -> v``) when the family does not use the
    pipeline's velocity; one-step predictions then use it too, so fit and scoring agree.
    ``sign`` is the model slot's sign in the balance.
    """

    force: SINDyForceModel
    eom: EquationOfMotion | None
    free_run: FreeRunResult | None
    velocity: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    velocity_label: str = "the pipeline's velocity estimate (denoise section)"
    sign: int = 1
    skipped: str = ""  # why there is no free run

    def predict(self, data: FitData) -> np.ndarray:
        """One-step force on ``data``'s rows (v re-estimated from whole logs if need be)."""
        frame = data.frame(VARIABLES)
        if self.velocity is not None:
            frame = with_velocity(frame, sequences(data.signals), self.velocity)
        return self.sign * self.force.predict(frame)

    def structure(self):
        from hmid.balance import Structure
        from hmid.balance.kinds import ChannelTerm, ConstantTerm, SmoothCoulombTerm

        terms = []
        for k, (feature, c) in enumerate(zip(self.force.features_, self.force.coef_, strict=True)):
            if c == 0:
                continue
            name = f"C{k}"
            if feature.term is None:
                terms.append(SmoothCoulombTerm(name=name, scale=self.force.v0, sign=self.sign,
                                               positive=False))  # fmt: skip
            elif feature.term.powers:
                terms.append(ChannelTerm(name=name, channel=feature.term.name, sign=self.sign))
            else:
                terms.append(ConstantTerm(name=name, sign=self.sign))
        return Structure.of(terms)

    def report_extras(self) -> Extras:
        force = self.force
        text = [
            "Equation of motion from the rig's declared balance and motion"
            + (f": `{self.eom.text()}`" if self.eom is not None else ""),
            _threshold_text(force),
            _inclusion_text(force),
            f"Velocity: {self.velocity_label}. Rows with |v| < {force.stick_speed:g} m/s "
            f"(block stuck or about to: static friction indeterminate, velocity sign "
            f"unreliable) are left out of the fit "
            f"({force.n_stuck_} here, besides those the split already excluded).",
        ]
        tables = []
        if force.path_ is not None:
            tables.append((force.path_.table(), "Threshold path: blocked cross-validation"))
        if force.choice_ is not None:
            names = [f.pretty for f in force.features_]
            tables.append((force.choice_.table(names).head(12),
                           "Candidate supports: blocked cross-validation"))  # fmt: skip
        figures = []
        if self.free_run is not None:
            text.append(self.free_run.text())
            tables.append((self.free_run.table(), "Free run on held-out blocks"))
            if self.free_run.blocks:
                figures.append(FigureSpec(plot_free_run, (self.free_run,), "free_run.png",
                                          "Free run of the discovered equation of motion on "
                                          "held-out blocks: measured vs simulated x"))  # fmt: skip
        else:
            text.append(f"Free run: skipped ({self.skipped or 'no held-out block'}).")
        return Extras("\n\n".join(text), tables, figures)


#: What no interval of the family includes.
INTERVAL_CAVEAT = (
    "Neither interval method includes bias from the velocity estimate, the smoothing lag, the "
    "force reconstruction or a term missing from the library: an interval can be narrow and "
    "still miss the truth."
)


def interval_note(force: SINDyForceModel) -> str:
    """The note on the coefficient intervals: method, level, calibration, what they leave out."""
    return f"{force.interval_method()}. {INTERVAL_CAVEAT}"


def _threshold_text(force: SINDyForceModel) -> str:
    if force.path_ is None:
        text = f"Threshold: {force.threshold_:.3g} (fixed in the config)."
    else:
        path = force.path_
        rule = "one-standard-error rule" if path.rule == "one_se" else "minimum CV error"
        terms = int(path.n_terms[np.searchsorted(path.thresholds, path.plateau[0])])
        text = (
            f"Threshold {force.threshold_:.3g} (a term is kept if its RMS contribution exceeds "
            f"this fraction of the standard deviation of F_m), chosen on the training rows only "
            f"by {path.folds}-fold blocked cross-validation along {len(path.thresholds)} "
            f"thresholds ({rule}; the middle of the run {path.plateau[0]:.3g}–"
            f"{path.plateau[1]:.3g} that keeps the same {terms} terms)."
        )
    choice = force.choice_
    if choice is None:
        return text
    rule = "fewest terms within the one-standard-error bound" if choice.rule == "one_se" else ""
    return text + (
        f" Support: the {rule or 'least error'} by the same cross-validation among the "
        f"{len(choice.cv_mse)} "
        "supports that the threshold path and the bootstrap's fits keep (on a path alone, "
        "correlated noise can hide the right support; see hmid.models.sindy._select)."
    )


def _inclusion_text(force: SINDyForceModel) -> str:
    names = [f.pretty for f in force.features_]
    kept = [n for n, k in zip(names, force.kept_, strict=True) if k]
    unsure = [
        f"{n} ({p:.2f})"
        for n, p, k in zip(names, force.inclusion_, force.kept_, strict=True)
        if 0.2 <= p < 0.8 and not k
    ]
    if force.intervals == "bootstrap":
        interval = (
            "interval = percentile interval of its coefficient over the fits (zeros included)"
        )
    else:
        interval = (
            "interval = the OLS refit's on the selected terms, from the residual's "
            "autocovariance, conditional on the selected support (left-out terms have none)"
        )
    return (
        f"Uncertainty: {force.n_models} STLSQ fits on a blocked bootstrap ({force.n_blocks_} "
        f"blocks of {force.block_seconds:g} s, seed {force.seed}); inclusion = fraction of the "
        f"fits that keep a term (is it in the model?); {interval}. "
        + (f"Kept by the config (never thresholded): {', '.join(kept)}. " if kept else "")
        + (
            f"Terms in doubt (inclusion 0.2–0.8): {', '.join(unsure)}."
            if unsure
            else "No term has an inclusion probability between 0.2 and 0.8."
        )
    )


def with_velocity(
    frame: pd.DataFrame,
    sequences: Mapping[str, pd.DataFrame],
    velocity: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> pd.DataFrame:
    """``frame`` (columns log, t, ...) with ``v`` from ``velocity`` on each whole log."""
    out = frame.copy()
    for name, rows in frame.groupby("log", sort=False):
        full = sequences[name]
        v = velocity(full["t"].to_numpy(), full["x"].to_numpy())
        index = np.searchsorted(full["t"].to_numpy(), rows["t"].to_numpy())
        out.loc[rows.index, "v"] = v[index]
    return out


def plot_free_run(result: FreeRunResult, path: Path) -> Path:
    """Measured and simulated x over the held-out blocks (end to end), and their difference."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 6))
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    offset = 0.0
    for k, block in enumerate(result.blocks):
        t = block.t - block.t[0] + offset
        top.plot(t, 1e3 * block.x_measured, color="0.55", lw=1.0,
                 label="measured x" if k == 0 else None)  # fmt: skip
        top.plot(t, 1e3 * block.x_simulated, color="C0", lw=0.9,
                 label="free run" if k == 0 else None)  # fmt: skip
        bottom.plot(t, 1e3 * (block.x_simulated - block.x_measured), color="C3", lw=0.8)
        top.axvline(offset, color="0.85", lw=0.8)
        top.text(offset, 1.0, f" {block.log}", transform=top.get_xaxis_transform(), va="top",
                 fontsize=7, color="0.4")  # fmt: skip
        if block.failed_at is not None:
            when = block.failed_at - block.t[0] + offset
            for ax in (top, bottom):
                ax.axvline(when, color="C3", ls="--", lw=1.0)
            top.text(when, 0.5, f" {block.status} at t = {block.failed_at:.3f} s", color="C3",
                     transform=top.get_xaxis_transform(), fontsize=8)  # fmt: skip
        offset = t[-1] + 0.2
    rmse = result.rmse
    top.set(ylabel="x [mm]", title="Free run of the discovered ODE, driven by measured P"
            + (f" (x RMSE {1e3 * rmse:.3g} mm)" if math.isfinite(rmse) else ""))  # fmt: skip
    top.legend(loc="lower right", fontsize=8)
    bottom.axhline(0, color="k", lw=0.6)
    bottom.set(xlabel="held-out time, blocks end to end [s]", ylabel="simulated − measured [mm]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path
