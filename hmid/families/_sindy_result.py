"""What the SINDy family hands the pipeline: the force map for one-step scoring, its terms (the
structure that the model file states and the free run integrates, as for every family) and the
report's extra text and tables."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.families.base import Extras, FitData, FittedModel
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
    """A fitted SINDy variant: ``force``, the force map (one-step).

    ``velocity`` re-estimates v of a whole log (``(t, x) -> v``) when the family does not use the
    pipeline's velocity; one-step predictions then use it too, so fit and scoring agree.
    ``sign`` is the model slot's sign in the balance.
    """

    force: SINDyForceModel
    velocity: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    velocity_label: str = "the pipeline's velocity estimate (denoise section)"
    sign: int = 1

    def predict(self, data: FitData) -> np.ndarray:
        """One-step force on ``data``'s rows (v re-estimated from whole logs if need be)."""
        frame = data.frame(VARIABLES)
        if self.velocity is not None:
            frame = with_velocity(frame, sequences(data.signals), self.velocity)
        return self.sign * self.force.predict(frame)

    @property
    def covariance(self) -> np.ndarray:
        """The selected coefficients' covariance (the intervals' own), in :meth:`structure`'s
        order: the terms are the selected features, in library order, at their physical
        coefficients (the slot's sign, common to all, leaves it as it is)."""
        return self.force.cov_

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
        return Extras("\n\n".join(text), tables, [])


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
