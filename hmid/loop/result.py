"""What the loop concluded: the effects it added, the scores before and after, the diagnostics,
and a verdict that names no effect without evidence."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np
import pandas as pd

from hmid.balance import Signals, StructureFit, parameters
from hmid.loop.decision import Decision, decision_table
from hmid.loop.diagnostics import Diagnostics, diagnose
from hmid.loop.hint import Hint, sparse_hint
from hmid.metrics import Scores, score


class Verdict(Enum):
    """What the loop concluded; its value is the report's wording."""

    EXPLAINED = "explained"  # effects added, and no residual pattern remains
    NOTHING_ATTRIBUTABLE = "no attributable structure"  # nothing added, and no pattern remains
    PATTERN_REMAINS = "unexplained structure"  # a signal still explains part of the residual


@dataclass(frozen=True)
class Alternative:
    """Rival physics that explains the residual about as well as an added effect."""

    name: str
    title: str
    physics: str
    parameters: pd.DataFrame
    gap: float  # its out-of-fold RMSE relative to the added effect's, less 1
    separating: str  # the experiment that would tell the two apart


@dataclass(frozen=True)
class Effect:
    """An added effect: its parameters with intervals, the evidence that pointed to it, and the
    rivals the data cannot tell from it."""

    name: str
    title: str
    physics: str
    parameters: pd.DataFrame
    evidence: str
    alternatives: tuple[Alternative, ...] = ()

    @property
    def named(self) -> tuple[str, ...]:
        """What the data say: this effect, or any of its indistinguishable rivals."""
        return (self.name, *(a.name for a in self.alternatives))

    def verdict(self) -> str:
        if not self.alternatives:
            return self.title
        return "indistinguishable on these data: " + " or ".join(self.named)


@dataclass(frozen=True)
class LoopResult:
    base_name: str  # the model the loop started from
    after_name: str  # that model with the added effects
    unit: str  # of the explained quantity
    base_parameters: pd.DataFrame  # its terms refitted by least squares, with intervals
    decisions: tuple[Decision, ...]  # every candidate of every round
    effects: tuple[Effect, ...]
    before: Scores  # the base model's own prediction, on the loop's held-out rows
    after: Scores
    diagnostics_before: Diagnostics
    diagnostics_after: Diagnostics
    verdict: Verdict
    message: str
    hint: Hint | None = None
    data: Signals | None = field(default=None, repr=False)  # the rows analysed
    residual_before: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)
    residual_after: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)
    # held-out scores after each added effect in turn (reported, never decided on)
    steps: tuple[tuple[str, Scores], ...] = ()
    # wall seconds of each part (name, seconds, candidates screened in it): the only numbers
    # that differ between runs of the same config and data
    costs: tuple[tuple[str, float, int], ...] = ()

    def cost_text(self) -> str:
        """The loop's wall time by part, per screened candidate where it screened."""
        if not self.costs:
            return ""
        parts = [
            f"{part} {seconds:.2f} s" + (f" ({seconds / n:.3f} s each)" if n else "")
            for part, seconds, n in self.costs
        ]
        total = sum(seconds for _, seconds, _ in self.costs)
        return f"The loop took {total:.1f} s: " + "; ".join(parts) + "."

    @property
    def tests(self) -> pd.DataFrame:
        """The decisions as the report's table of every candidate tested, per round."""
        return decision_table(self.decisions)

    @property
    def first_effect(self) -> str | None:
        return self.effects[0].name if self.effects else None

    @property
    def first_named(self) -> tuple[str, ...]:
        """The first effect and its indistinguishable rivals (empty if none was added)."""
        return self.effects[0].named if self.effects else ()


def own_parameters(
    candidate, fitted: StructureFit, interval, signals: Signals, confidence, model=()
):
    """A candidate's own parameters in ``fitted`` (intervals for its residual's correlation; a
    profiled parameter keeps its profile-likelihood interval), less those the ``model`` names
    already had (a Coulomb level the candidate shares with it)."""
    table = parameters(fitted, signals, confidence)
    own_columns = set(candidate.columns(fitted.structure.seen(signals),
                                        fitted.structure.terms[-1].value).names)  # fmt: skip
    own_columns -= set(model)
    own = table[table["parameter"].isin(own_columns)].drop(columns=["positive"])
    if candidate.hyper is not None:
        hyper = candidate.hyper
        low, high = interval if interval is not None else (np.nan, np.nan)
        value = fitted.structure.terms[-1].value
        profiled = {"parameter": hyper.name, "value": value, "std. error": np.nan,
                    "lower": low, "upper": high, "unit": hyper.unit}  # fmt: skip
        own = pd.concat([own, pd.DataFrame([profiled])], ignore_index=True)
    return own.reset_index(drop=True)


def make_effect(screened, trial: StructureFit, current: StructureFit, signals: Signals,
                decision: Decision, folds, confidence: float,
                alternatives=()) -> Effect:  # fmt: skip
    """The added effect (``screened``: its screen; ``decision``: the evidence for it) with
    parameters from ``trial``, the joint fit every parameter was profiled afresh in."""
    candidate = screened.candidate
    table = own_parameters(candidate, trial, screened.interval, signals, confidence,
                           current.columns.names)  # fmt: skip
    d = decision
    text = (
        f"round {d.round}, training rows: F = {d.f:.1f} on n_eff = {d.n_eff:.0f}, "
        f"Holm-adjusted p = {d.p_holm:.2g}, ΔBIC = {d.delta_bic:.1f}; selection by "
        f"{int(folds.fold.max()) + 1}-fold blocked cross-validation over {folds.blocks} time "
        f"blocks: out-of-fold RMSE {100 * d.cv_change:+.2f} % (block bootstrap, "
        f"{confidence:.0%} upper bound {100 * d.cv_upper:+.2f} %)"
    )
    return Effect(candidate.name, candidate.title, candidate.physics, table, text,
                  tuple(alternatives))  # fmt: skip


def _residual_before(signals: Signals, prediction: np.ndarray) -> np.ndarray:
    return signals.target - prediction


def finish(spec, signals, base, start, current, effects, decisions, held, steps=()) -> LoopResult:
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
    verdict = _verdict(spec, after, effects)
    hint = None
    if verdict is Verdict.PATTERN_REMAINS and spec.hint:
        hint = sparse_hint(current_residual, signals, after.strongest[0])
        if hint.heldout_r2 <= 0 and not hint.periodic:
            hint = None  # a hint that explains no held-out variance is no hint
    before_scores = score(signals.target[held], base.prediction[held], "one-step")
    after_scores = before_scores if not effects else current.scores(held)
    table = parameters(start, signals, spec.confidence)
    return LoopResult(
        base_name=base.name,
        after_name=base.name + "".join(f" + {e.name}" for e in effects),
        unit=signals.unit("target"),
        base_parameters=table.drop(columns=["positive"]),
        decisions=tuple(decisions),
        effects=tuple(effects),
        before=before_scores,
        after=after_scores,
        diagnostics_before=before,
        diagnostics_after=after,
        verdict=verdict,
        message=_message(spec, after, effects, verdict),
        hint=hint,
        data=signals,
        residual_before=residual_before,
        residual_after=current_residual,
        steps=tuple(steps),
    )


def _verdict(spec, after: Diagnostics, effects) -> Verdict:
    """A residual pattern remains where a signal explains ``structure_threshold`` of it."""
    if after.strongest[1] >= spec.structure_threshold:
        return Verdict.PATTERN_REMAINS
    return Verdict.EXPLAINED if effects else Verdict.NOTHING_ATTRIBUTABLE


def _message(spec, after: Diagnostics, effects, verdict: Verdict) -> str:
    """The verdict in words: what was added, the pattern left, the whiteness test."""
    signal, eta2 = after.strongest
    names = "; ".join(e.verdict() for e in effects)
    white = (
        f"Ljung-Box on the residual every {spec.stride_s * 1e3:.0f} ms: p = {after.ljung_box_p:.2g}"
    )
    if verdict is Verdict.PATTERN_REMAINS:
        return (
            f"Structure remains that no candidate effect explains: the residual depends on "
            f"{signal} (cross-fitted η² = {eta2:.3f} ≥ {spec.structure_threshold}); {white}. "
            + (f"Added before that: {names}. " if effects else "No candidate effect is claimed. ")
        )
    return (
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
