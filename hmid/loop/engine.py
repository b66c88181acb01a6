"""The loop: fit the base, test every candidate effect, add the best confirmed one, repeat.

See :class:`hmid.loop.config.LoopSpec` for the acceptance rule. Everything is deterministic:
profiled parameters are chosen on fixed grids and fits are least squares.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import pandas as pd

from hmid.loop.bases import Base
from hmid.loop.candidates import Candidate, make_candidates
from hmid.loop.config import LoopSpec
from hmid.loop.data import LoopData
from hmid.loop.design import Columns, LeastSquares
from hmid.loop.diagnostics import Diagnostics, diagnose, lag_count
from hmid.loop.hint import Hint, sparse_hint
from hmid.loop.statistics import (
    NestedTest,
    autocorrelation,
    inference,
    integrated_time,
    profile_interval,
)
from hmid.metrics import Scores, score


@dataclass(frozen=True)
class Term:
    candidate: Candidate
    value: float | None


@dataclass(frozen=True)
class Structure:
    """Base at a hyperparameter value plus added effects; ``elastic`` from the last base fit."""

    base: Base
    base_value: float | None
    effects: tuple[Term, ...] = ()
    elastic: np.ndarray | None = None

    def plus(self, term: Term) -> Structure:
        return replace(self, effects=(*self.effects, term))

    def data_for(self, data: LoopData) -> LoopData:
        for term in self.effects:
            data = term.candidate.transform(data, term.value)
        return data

    def columns(self, data: LoopData, cache: dict | None = None) -> Columns:
        seen = self.data_for(data)
        columns = self.base.columns(seen, self.base_value, cache)
        elastic = self.elastic if self.elastic is not None else np.zeros(len(data))
        for term in self.effects:
            extra = term.candidate.columns(seen, term.value, elastic)
            # a correction two effects share, or one the base has (the Coulomb level), enters once
            keep = [
                i
                for i, name in enumerate(extra.names)
                if name not in columns.names
                and not any(
                    np.array_equal(extra.values[:, i], columns.values[:, j])
                    for j in range(columns.width)
                )
            ]
            columns = columns + Columns(
                tuple(extra.names[i] for i in keep),
                tuple(extra.units[i] for i in keep),
                extra.values[:, keep],
            )
        return columns


@dataclass(frozen=True)
class StructureFit:
    structure: Structure
    columns: Columns
    fit: LeastSquares
    y: np.ndarray = field(repr=False)

    @cached_property
    def residual(self) -> np.ndarray:
        """On every row (fitted on the training rows only)."""
        return self.y - self.fit.predict(self.columns)

    @property
    def params(self) -> dict[str, float]:
        return dict(zip(self.columns.names, self.fit.coef, strict=True))

    def held_out(self, data: LoopData) -> Scores:
        rows = data.validation
        return score(data["y"][rows], data["y"][rows] - self.residual[rows], "one-step")


def _fit(structure: Structure, data: LoopData, cache: dict) -> StructureFit:
    columns = structure.columns(data, cache)
    fit = LeastSquares.fit(columns, data["y"], data.train)
    return StructureFit(structure, columns, fit, data["y"])


def _descend(structure: Structure, data: LoopData, cache: dict) -> StructureFit:
    """The base hyperparameter near the current one: walk the grid while the SSE falls."""
    grid = structure.base.grid
    best = _fit(structure, data, cache)
    if len(grid) == 1:
        return best
    start = grid.index(structure.base_value)
    for step in (-1, 1):
        j = start + step
        while 0 <= j < len(grid):
            trial = _fit(replace(structure, base_value=grid[j]), data, cache)
            if trial.fit.sse >= best.fit.sse:
                break
            best, j = trial, j + step
        if best.structure.base_value != structure.base_value:
            break
    return best


def _refit(structure: Structure, data: LoopData, cache: dict, *, full: bool = False):
    """Re-profile the base's hyperparameter with the effects in (the whole grid, or a walk from
    the current value), then update the elastic force the drift terms use."""
    if full:
        grid = structure.base.grid
        sse = [_fit(replace(structure, base_value=v), data, cache).fit.sse for v in grid]
        structure = replace(structure, base_value=grid[int(np.argmin(sse))])
    best = _descend(structure, data, cache)
    s = best.structure
    elastic = s.base.elastic(s.data_for(data), s.base_value, best.params, cache)
    return _fit(replace(s, elastic=elastic), data, cache)


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


def _hypers(structure: Structure) -> int:
    return (structure.base.hyper is not None) + sum(
        t.candidate.hyper is not None for t in structure.effects
    )


def _screen(current: StructureFit, candidate: Candidate, data, spec, cache):
    """Profile the candidate's parameter and the base's jointly (coordinate-wise: the base
    absorbed part of the effect, so its hyperparameter moves once the effect is in), and test
    it on the effective sample size of the *augmented* model's residual: the current residual
    still holds the effect, whose persistence would inflate tau_int and hide it."""
    base = current.structure
    sign = base.base.friction_sign(current.params)
    for _ in range(3):
        fits = [_fit(base.plus(Term(candidate, g)), data, cache) for g in candidate.grid]
        sse = np.array([f.fit.sse for f in fits])
        signs = np.array([all(sign * f.params[k] > 0 for k in candidate.positive) for f in fits])
        best = int(np.argmin(np.where(signs, sse, np.inf))) if signs.any() else int(np.argmin(sse))
        joint = _descend(base.plus(Term(candidate, candidate.grid[best])), data, cache)
        if joint.structure.base_value == base.base_value:
            break
        base = replace(base, base_value=joint.structure.base_value)
    q = joint.columns.width - current.columns.width + (candidate.hyper is not None)
    p1 = joint.columns.width + _hypers(joint.structure)
    n_eff = current.fit.n / _tau_int(joint.residual, data)
    test = NestedTest.of(current.fit.sse, joint.fit.sse, q, p1, current.fit.n, n_eff)
    grid = np.array([np.nan if g is None else g for g in candidate.grid], dtype=float)
    interval = profile_interval(grid, sse, n_eff, spec.confidence) if candidate.hyper else None
    identified = bool(signs[best]) and all(sign * joint.params[k] > 0 for k in candidate.positive)
    return candidate.grid[best], test, interval, identified, n_eff, joint.fit.sse


def _parameters(fitted: StructureFit, data: LoopData, tau_int: float, confidence: float):
    return inference(fitted.columns, data["y"], data.train, tau_int, confidence)


def run_loop(data: LoopData, spec: LoopSpec) -> LoopResult:
    """Diagnose, test, confirm and add effects; then say what remains."""
    from threadpoolctl import threadpool_limits

    # hundreds of small least-squares problems: BLAS threads only contend for the cores
    with threadpool_limits(limits=1, user_api="blas"):
        return _run_loop(data, spec)


def _run_loop(data: LoopData, spec: LoopSpec) -> LoopResult:
    candidates = make_candidates(spec.candidates)
    data = data.trim_segment_ends(max((c.tail_s for c in candidates), default=0.0))
    cache: dict = {}
    current = _refit(Structure(spec.base, spec.base.grid[0]), data, cache, full=True)
    start = current
    rows, effects, remaining = [], [], list(candidates)
    for round_no in range(1, spec.max_effects + 1):
        if not remaining:
            break
        screened = [(c, *_screen(current, c, data, spec, cache)) for c in remaining]
        p_holm = _holm([row[2].p_value for row in screened])
        held_rmse = current.held_out(data).rmse
        # rank on one sample size for all: each candidate's own n_eff (its residual's) decides
        # significance, but would favour whichever whitens its residual most, not fits best
        n_common = current.fit.n / _tau_int(current.residual, data)
        round_rows = [
            _row(round_no, current, screen, p_adj, n_common, spec)
            for screen, p_adj in zip(screened, p_holm, strict=True)
        ]
        order = sorted(
            (i for i, r in enumerate(round_rows) if r["passes training"]),
            key=lambda i: round_rows[i]["ΔBIC (rank)"],
        )
        added = None
        for i in order:
            candidate, value = screened[i][0], screened[i][1]
            trial = _refit(current.structure.plus(Term(candidate, value)), data, cache)
            rmse = trial.held_out(data).rmse
            change = rmse / held_rmse - 1.0
            round_rows[i] |= {"held-out RMSE [N]": rmse, "held-out change": change}
            if change <= -spec.margin:
                round_rows[i]["added"] = True
                added = (candidate, trial, round_rows[i], screened[i][3])
                break
        rows.extend(round_rows)
        if added is None:
            break
        candidate, trial, evidence, interval = added
        table = _parameters(trial, data, _tau_int(trial.residual, data), spec.confidence)
        own = table[~table["parameter"].isin(current.columns.names)]
        sign = trial.structure.base.friction_sign(trial.params)
        if candidate.friction and sign < 0:  # shown as friction, whatever the log's convention
            own = own.assign(value=-own["value"], lower=-own["upper"], upper=-own["lower"])
        value = trial.structure.effects[-1].value
        effects.append(_effect(candidate, own, value, interval, evidence, held_rmse))
        remaining.remove(candidate)
        current = trial
        strongest = diagnose(current.residual, data, max_lag_s=spec.max_lag_s).strongest[1]
        if strongest < spec.structure_threshold:
            break
    return _finish(spec, data, start, current, effects, pd.DataFrame(rows))


def _row(round_no, current: StructureFit, screen, p_adj: float, n_common: float, spec) -> dict:
    candidate, value, test, interval, signs, n_eff, sse = screen
    identified = signs and candidate.identified(value)
    rank = NestedTest.of(current.fit.sse, sse, test.q, 0, current.fit.n, n_common)
    return {
        "round": round_no,
        "candidate": candidate.name,
        "profiled": _profiled(candidate, value, interval),
        "F": test.f,
        "n_eff": n_eff,
        "p": test.p_value,
        "p (Holm)": p_adj,
        "ΔBIC": test.delta_bic,
        "ΔBIC (rank)": rank.delta_bic,
        "identified": identified,
        "passes training": bool(p_adj < spec.alpha and test.delta_bic < 0 and identified),
        "held-out RMSE [N]": np.nan,
        "held-out change": np.nan,
        "added": False,
    }


def _tau_int(residual: np.ndarray, data: LoopData) -> float:
    """Integrated autocorrelation time of the training residual, with lags up to 10 s."""
    nlags = min(lag_count(data, 10.0), max(int(data.train.sum()) // 20, 2))
    return integrated_time(autocorrelation(residual, data.train, data, nlags))


def _holm(p: list[float]) -> np.ndarray:
    from statsmodels.stats.multitest import multipletests

    return multipletests(p, method="holm")[1] if p else np.array([])


def _profiled(candidate: Candidate, value, interval) -> str:
    if candidate.hyper is None:
        return ""
    name, unit = candidate.hyper
    return f"{name} = {value:.4g} {unit} [{interval[0]:.4g}, {interval[1]:.4g}]"


def _effect(candidate, own, value, interval, evidence, held_rmse) -> Effect:
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


def _finish(spec, data, start, current, effects, tests) -> LoopResult:
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
            hint = sparse_hint(current.residual, data)
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
                "x, v, P, dP/dt or t (sensor resolution and filtering correlate neighbouring "
                "samples)."
                if after.ljung_box_p < 0.01
                else "."
            )
        )
    base_table = _parameters(start, data, _tau_int(start.residual, data), spec.confidence)
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
