"""What the loop concluded: the effects it added, the scores before and after, the diagnostics,
and a verdict that names no effect without evidence."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np
import pandas as pd

from hmid.balance import Signals, StructureFit, parameters
from hmid.loop.decision import Decision, decision_table
from hmid.loop.declared import Finding
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
class AddedEffect:
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
    effects: tuple[AddedEffect, ...]
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
    # what the console and the report must say in one line each: a base that fell back to
    # another model, an addition after which the held-out error rose
    notes: tuple[str, ...] = ()
    # every parameter after the loop (the base's and each added effect's, part says whose),
    # from the last joint fit
    final_parameters: pd.DataFrame = field(default_factory=pd.DataFrame)
    # declared terms found inconsistent with the dynamic data (their lines are among the notes)
    findings: tuple[Finding, ...] = ()

    def final_lines(self) -> tuple[str, ...]:
        """One line per part of the final model (the base, each added effect): its parameters
        with units and intervals."""
        table = self.final_parameters
        if table.empty:
            return ()
        lines = []
        for part, rows in table.groupby("part", sort=False):
            values = "; ".join(
                f"{r.parameter} = {r.value:.4g} {r.unit} [{_bound(r.lower)}, {_bound(r.upper)}]"
                for r in rows.itertuples()
            )
            lines.append(f"{part}: {values}")
        return tuple(lines)

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


def _bound(value: float) -> str:
    """An interval's end as printed: "undefined" where its standard error is."""
    return f"{value:.4g}" if np.isfinite(value) else "undefined"


def final_parameters(current: StructureFit, base_terms: int, base_name: str, effects,
                     signals: Signals, confidence: float) -> pd.DataFrame:  # fmt: skip
    """Every parameter of the model after the loop, from its last joint fit: the base's
    (refitted) and each added effect's, with value, unit and interval; ``part`` says whose
    (the first ``base_terms`` terms are the base's, then one per effect in turn)."""
    table = parameters(current, signals, confidence).drop(columns=["positive"])
    seen = current.structure.seen(signals)
    owner: dict[str, str] = {}
    for i, placed in enumerate(current.structure.terms):
        part = base_name if i < base_terms else effects[i - base_terms].name
        for name in placed.term.columns(seen, placed.value).names:
            owner.setdefault(name, part)  # a column an effect shares is the base's
        if placed.term.hyper is not None:
            owner.setdefault(placed.term.hyper.name, part)
    table.insert(0, "part", [owner.get(p, base_name) for p in table["parameter"]])
    return table


def outside(table: pd.DataFrame) -> list[str]:
    """The parameters of a table (columns parameter, value, lower, upper) whose printed
    interval does not contain its estimate (an undefined interval, NaN, contains nothing and
    claims nothing)."""
    if table.empty:
        return []
    value, low, high = (table[c].to_numpy(dtype=float) for c in ("value", "lower", "upper"))
    bad = (low > value) | (value > high)  # NaN compares False: undefined, not wrong
    return [str(p) for p in table["parameter"][bad]]


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
        assert value is not None  # a profiled term is placed at a value
        # the interval is the screen's profile's; a joint refit may move the value a little
        # within its flat bottom, and the printed interval always holds the estimate
        low, high = min(low, value), max(high, value)
        profiled = {"parameter": hyper.name, "value": value, "std. error": np.nan,
                    "lower": low, "upper": high, "unit": hyper.unit}  # fmt: skip
        own = pd.concat([own, pd.DataFrame([profiled])], ignore_index=True)
    return own.reset_index(drop=True)


def added_effect(screened, trial: StructureFit, current: StructureFit, signals: Signals,
                decision: Decision, folds, confidence: float,
                alternatives=()) -> AddedEffect:  # fmt: skip
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
        + (
            f"; with every training log left out whole in turn: {100 * d.cv_across:+.2f} % "
            f"(upper bound {100 * d.cv_across_upper:+.2f} %)"
            if d.cv_across == d.cv_across  # not NaN: the split holds out whole logs
            else ""
        )
    )
    return AddedEffect(candidate.name, candidate.title, candidate.physics, table, text,
                  tuple(alternatives))  # fmt: skip


def _residual_before(signals: Signals, prediction: np.ndarray) -> np.ndarray:
    return signals.target - prediction


def finish(spec, signals, base, start, current, effects, decisions, held, steps=(),
           held_out: str = "rows", fitted_level: str | None = None,
           findings: tuple[Finding, ...] = ()) -> LoopResult:  # fmt: skip
    """Diagnostics before (the base model's own residual) and after, and the verdict; the
    held-out error before and after on ``held``, the comparison's held-out rows (a lead's reach
    at segment ends is left out of the tests, not of the reported error; ``held_out`` says what
    they are: "rows" or whole "logs"; ``fitted_level``: the declared level's name where the
    base fitted it, which its refit, the same column, is called in the tables; ``findings``:
    the declared terms found wrong (:func:`hmid.loop.declared.decide`), the corrections of
    those in the balance already in ``start``)."""
    residual_before = _residual_before(signals, base.prediction)
    before_scores = score(signals.target[held], base.prediction[held], "one-step")
    table = parameters(start, signals, spec.confidence)
    refitted = [f.parameter for f in findings if f.refitted]
    before = _diagnose(spec, signals, residual_before)
    after, current_residual = before, residual_before  # nothing added: after is before
    corrected = bool(effects) or bool(refitted)  # a known value found wrong: corrected
    if corrected:
        current_residual = current.residual
        after = _diagnose(spec, signals, current_residual)
    verdict = _verdict(spec, after, effects)
    hint = _hint(spec, verdict, current_residual, signals, after)
    after_scores = current.scores(held) if corrected else before_scores
    final = final_parameters(current, len(start.structure.terms), base.name, effects, signals,
                             spec.confidence)  # fmt: skip
    if fitted_level is not None:  # the refit replaced the fitted level: its name, not a change
        _rename_level(table, final, fitted_level, base.name)
    return LoopResult(
        base_name=base.name,
        after_name=base.name
        + _refitted(refitted, effects)
        + "".join(f" + {e.name}" for e in effects),
        unit=signals.unit("target"),
        base_parameters=table.drop(columns=["positive"]),
        final_parameters=final,
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
        findings=tuple(findings),
        notes=(
            *(f.message for f in findings),
            *rises(before_scores, steps, signals.unit("target"), held_out),
        ),
    )


def _refitted(corrections: list[str], effects) -> str:
    """The after's name where only corrections of declared values changed the base."""
    if not corrections or effects:
        return ""
    if corrections == ["dFc"]:
        return " + dFc (its known friction level refitted)"
    return f" + {', '.join(corrections)} (declared values refitted)"


def _diagnose(spec, signals, residual: np.ndarray) -> Diagnostics:
    """The residual's diagnostics on the spec's lags."""
    return diagnose(residual, signals, max_lag_s=spec.max_lag_s, stride_s=spec.stride_s)


def _hint(spec, verdict: Verdict, residual: np.ndarray, signals, after):
    """The sparse hint at the structure that remains, where a pattern remains and the spec asks
    for one (None otherwise)."""
    if verdict is not Verdict.PATTERN_REMAINS or not spec.hint:
        return None
    hint = sparse_hint(residual, signals, after.strongest[0])
    if hint.heldout_r2 <= 0 and not hint.periodic:
        return None  # a hint that explains no held-out variance is no hint
    return hint


def _rename_level(table: pd.DataFrame, final: pd.DataFrame, level: str, base: str) -> None:
    """Call the base's refit of its fitted Coulomb level (dFc) by the level's name, in place."""
    rename = {"dFc": level}
    table["parameter"] = table["parameter"].replace(rename)
    ours = final["part"] == base
    final.loc[ours, "parameter"] = final.loc[ours, "parameter"].replace(rename)


#: a held-out RMSE more than this fraction above the one before an addition has risen
RISE = 1e-3


def rises(before: Scores, steps, unit: str, held_out: str = "rows") -> tuple[str, ...]:
    """One line per addition after which the held-out error rose (reported: the held-out rows
    decide nothing, but an addition that does worse on them does not generalise)."""
    out, previous = [], before.rmse
    for name, scores in steps:
        if scores.rmse > previous * (1 + RISE):
            out.append(
                f"added {name}, but the held-out error rose {previous:.4g} → {scores.rmse:.4g} "
                f"{unit}: it does not generalise to the held-out {held_out}"
            )
        previous = scores.rmse
    return tuple(out)


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
        if effects:  # what the added effects left, not what they explained
            return (
                f"Added: {names}. Structure remains that no further candidate explains: what "
                f"they leave of the residual still depends on {signal} (cross-fitted η² = "
                f"{eta2:.3f} ≥ {spec.structure_threshold}); {white}."
            )
        return (
            f"Structure remains that no candidate effect explains: the residual depends on "
            f"{signal} (cross-fitted η² = {eta2:.3f} ≥ {spec.structure_threshold}); {white}. "
            "No candidate effect is claimed. "
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
