"""What the loop concluded: the effects it added, the scores before and after, the diagnostics,
and a verdict that names no effect without evidence."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hmid.loop.data import LoopData
from hmid.loop.diagnostics import Diagnostics, diagnose, residual_tau_int
from hmid.loop.hint import Hint, sparse_hint
from hmid.loop.structure import parameters
from hmid.metrics import Scores


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
    base_title: str
    base_equation: str
    base_parameters: pd.DataFrame
    tests: pd.DataFrame  # every candidate of every round
    effects: tuple[Effect, ...]
    before: Scores
    after: Scores
    diagnostics_before: Diagnostics
    diagnostics_after: Diagnostics
    verdict: str  # "explained", "unexplained structure", "no attributable structure"
    message: str
    hint: Hint | None = None
    data: LoopData | None = field(default=None, repr=False)  # the rows analysed
    residual_before: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)
    residual_after: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)

    @property
    def first_effect(self) -> str | None:
        return self.effects[0].name if self.effects else None


def make_effect(candidate, own, value, interval, evidence, held_rmse) -> Effect:
    if candidate.hyper is not None:
        name, unit = candidate.hyper
        profiled = {"parameter": name, "value": value, "std. error": np.nan,
                    "lower": interval[0], "upper": interval[1], "unit": unit}  # fmt: skip
        own = pd.concat([own, pd.DataFrame([profiled])], ignore_index=True)
    text = (
        f"round {evidence['round']}: F = {evidence['F']:.1f} on n_eff = {evidence['n_eff']:.0f}, "
        f"Holm-adjusted p = {evidence['p (Holm)']:.2g}, ΔBIC = {evidence['ΔBIC']:.1f}; "
        f"held-out RMSE {held_rmse:.4g} → {evidence['held-out RMSE [N]']:.4g} N "
        f"({100 * evidence['held-out change']:+.1f} %)"
    )
    return Effect(
        candidate.name, candidate.title, candidate.physics, own.reset_index(drop=True), text
    )


def finish(spec, data, start, current, effects, tests, cache) -> LoopResult:
    before = diagnose(start.residual, data, max_lag_s=spec.max_lag_s, stride_s=spec.stride_s)
    after = diagnose(current.residual, data, max_lag_s=spec.max_lag_s, stride_s=spec.stride_s)
    signal, eta2 = after.strongest
    names = ", ".join(e.title for e in effects)
    white = (
        f"Ljung-Box on the residual every {spec.stride_s * 1e3:.0f} ms: p = {after.ljung_box_p:.2g}"
    )
    hint = None
    if eta2 >= spec.structure_threshold:
        verdict = "unexplained structure"
        if spec.hint:
            hint = sparse_hint(current.residual, data, signal)
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
                "x, v, P, dP/dt or t (possible causes: sensor resolution and the smoothing "
                "filters, which correlate neighbouring samples)."
                if after.ljung_box_p < 0.01
                else "."
            )
        )
    tau_int = residual_tau_int(start.residual, data)
    base_table = parameters(start, data, tau_int, spec.confidence, cache)
    return LoopResult(
        base_title=spec.base.title,
        base_equation=spec.base.equation(),
        base_parameters=base_table,
        tests=tests,
        effects=tuple(effects),
        before=start.held_out(data),
        after=current.held_out(data),
        diagnostics_before=before,
        diagnostics_after=after,
        verdict=verdict,
        message=message,
        hint=hint,
        data=data,
        residual_before=start.residual,
        residual_after=current.residual,
    )
