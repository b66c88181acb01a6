"""What the loop concluded: the effects it added, the scores before and after, the diagnostics,
and a verdict that names no effect without evidence."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hmid.balance import Signals, StructureFit, parameters
from hmid.balance.statistics import residual_tau_int
from hmid.loop.diagnostics import Diagnostics, diagnose
from hmid.loop.hint import Hint, sparse_hint
from hmid.metrics import Scores, score


@dataclass(frozen=True)
class Effect:
    """An added effect: its parameters with intervals, and the evidence that pointed to it."""

    name: str
    title: str
    physics: str
    parameters: pd.DataFrame
    evidence: str


@dataclass(frozen=True)
class LoopResult:
    base_name: str  # the model the loop started from
    after_name: str  # that model with the added effects
    unit: str  # of the explained quantity
    base_parameters: pd.DataFrame  # its terms refitted by least squares, with intervals
    tests: pd.DataFrame  # every candidate of every round
    effects: tuple[Effect, ...]
    before: Scores  # the base model's own prediction, on the loop's held-out rows
    after: Scores
    diagnostics_before: Diagnostics
    diagnostics_after: Diagnostics
    verdict: str  # "explained", "unexplained structure", "no attributable structure"
    message: str
    hint: Hint | None = None
    data: Signals | None = field(default=None, repr=False)  # the rows analysed
    residual_before: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)
    residual_after: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)

    @property
    def first_effect(self) -> str | None:
        return self.effects[0].name if self.effects else None


def make_effect(
    candidate, trial: StructureFit, current: StructureFit, signals: Signals, interval, evidence,
    held_rmse: float, confidence: float,
) -> Effect:  # fmt: skip
    """The added effect's own parameters (intervals on the augmented residual's n_eff; a
    profiled parameter keeps its profile-likelihood interval) and its evidence."""
    tau_int = residual_tau_int(trial.residual, signals)
    table = parameters(trial, signals, tau_int, confidence)
    hyper_names = [trial.structure.terms[i].term.hyper.name for i in trial.structure.hypers]
    own = table[~table["parameter"].isin([*current.columns.names, *hyper_names])]
    own = own.drop(columns=["positive"])
    if candidate.hyper is not None:
        value = trial.structure.terms[-1].value
        hyper = candidate.hyper
        profiled = {"parameter": hyper.name, "value": value, "std. error": np.nan,
                    "lower": interval[0], "upper": interval[1], "unit": hyper.unit}  # fmt: skip
        own = pd.concat([own, pd.DataFrame([profiled])], ignore_index=True)
    text = (
        f"round {evidence['round']}: F = {evidence['F']:.1f} on n_eff = {evidence['n_eff']:.0f}, "
        f"Holm-adjusted p = {evidence['p (Holm)']:.2g}, ΔBIC = {evidence['ΔBIC']:.1f}; "
        f"held-out RMSE {held_rmse:.4g} → {evidence['held-out RMSE']:.4g} "
        f"({100 * evidence['held-out change']:+.1f} %)"
    )
    return Effect(
        candidate.name, candidate.title, candidate.physics, own.reset_index(drop=True), text
    )


def _residual_before(signals: Signals, prediction: np.ndarray) -> np.ndarray:
    return signals.target - prediction


def finish(spec, signals, base, start, current, effects, tests, held) -> LoopResult:
    """Diagnostics before (the base model's own residual) and after, and the verdict; the
    held-out error before and after on ``held``, the comparison's held-out rows (a lead's reach
    at segment ends is left out of the tests, not of the reported error)."""
    residual_before = _residual_before(signals, base.prediction)
    before = diagnose(residual_before, signals, max_lag_s=spec.max_lag_s, stride_s=spec.stride_s)
    after, current_residual = before, residual_before  # nothing added: after is before
    if effects:
        current_residual = current.residual
        after = diagnose(
            current_residual, signals, max_lag_s=spec.max_lag_s, stride_s=spec.stride_s
        )
    signal, eta2 = after.strongest
    names = ", ".join(e.title for e in effects)
    white = (
        f"Ljung-Box on the residual every {spec.stride_s * 1e3:.0f} ms: p = {after.ljung_box_p:.2g}"
    )
    hint = None
    if eta2 >= spec.structure_threshold:
        verdict = "unexplained structure"
        if spec.hint:
            hint = sparse_hint(current_residual, signals, signal)
        message = (
            f"Structure remains that no candidate effect explains: the residual depends on "
            f"{signal} (cross-fitted η² = {eta2:.3f} ≥ {spec.structure_threshold}); {white}. "
            + (f"Added before that: {names}. " if effects else "No candidate effect is claimed. ")
        )
    else:
        verdict = "explained" if effects else "no attributable structure"
        message = (
            (f"Added: {names}. " if effects else "No candidate effect passed. ")
            + f"No signal explains {spec.structure_threshold:.0%} of the residual's variance "
            f"(largest: {signal}, η² = {eta2:.3f}); {white}"
            + (
                " — the residual is not white, but its correlation is not attributable to "
                "the scanned signals (possible causes: sensor resolution and the smoothing "
                "filters, which correlate neighbouring samples)."
                if after.ljung_box_p < 0.01
                else "."
            )
        )
    before_scores = score(signals.target[held], base.prediction[held], "one-step")
    after_scores = before_scores if not effects else current.scores(held)
    table = parameters(start, signals, residual_tau_int(start.residual, signals), spec.confidence)
    return LoopResult(
        base_name=base.name,
        after_name=base.name + "".join(f" + {e.name}" for e in effects),
        unit=signals.unit("target"),
        base_parameters=table.drop(columns=["positive"]),
        tests=tests,
        effects=tuple(effects),
        before=before_scores,
        after=after_scores,
        diagnostics_before=before,
        diagnostics_after=after,
        verdict=verdict,
        message=message,
        hint=hint,
        data=signals,
        residual_before=residual_before,
        residual_after=current_residual,
    )
