"""The loop: take a fitted model, test every candidate effect, add the best confirmed one, repeat.

See :class:`hmid.loop.config.LoopSpec` for the acceptance rule. The base is any fitted model of
the experiment: its own predictions are the "before", and its terms (the polynomial's monomials,
the SLS's springs and arm, SINDy's selected terms, the declared balance) are refitted by least
squares with each candidate added. Everything is deterministic: profiled parameters are chosen on
fixed grids and fits are least squares.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.balance import Signals, Structure, StructureFit, descend, profile, refine
from hmid.balance import fit as fit_structure
from hmid.balance.statistics import profile_interval, residual_tau_int
from hmid.families.base import FitData, Fitted
from hmid.loop.candidates import ELASTIC, Candidate, Setting, make_candidates
from hmid.loop.config import LoopSpec
from hmid.loop.diagnostics import structure_scan
from hmid.loop.result import LoopResult, finish, make_effect
from hmid.loop.statistics import NestedTest, holm


@dataclass(frozen=True)
class LoopBase:
    """The model the loop starts from: its name, its terms and its own prediction of the
    balance's ``target`` on every row (NaN where it has none)."""

    name: str
    structure: Structure
    prediction: np.ndarray

    @classmethod
    def of(cls, fitted: Fitted, data: FitData) -> LoopBase:
        """A fitted model (any family) as the loop's base, predicting on ``data``'s signals."""
        prediction = np.full(len(data.signals), np.nan)
        for role in ("train", "validation"):
            part = data.as_role(role)
            prediction[part.rows] = fitted.predict(part)
        return cls(fitted.name, fitted.model.structure(), prediction)


@dataclass(frozen=True)
class Screen:
    """One candidate tested against the current model in one round."""

    candidate: Candidate
    value: float | None  # its profiled parameter (None if it has none)
    test: NestedTest  # on the augmented residual's n_eff
    interval: tuple[float, float] | None  # profile-likelihood interval of ``value``
    physical: bool  # its sign-constrained parameters have their physical sign
    n_eff: float
    sse: float  # training SSE of the augmented model

    @property
    def identified(self) -> bool:
        return self.physical and self.candidate.identified(self.value)


def _physical(candidate: Candidate, fitted: StructureFit) -> bool:
    # a parameter missing from a fit is a column the model already has (merged): not constrained
    return all(fitted.params.get(k, 1.0) > 0 for k in candidate.positive)


def _with_elastic(signals: Signals, current: StructureFit, position: str | None) -> Signals:
    """``signals`` with the current model's elastic force: its terms that read the position
    alone, at their fitted coefficients (what a stiffness drift scales)."""
    elastic = np.zeros(len(signals))
    names = set()
    for placed in current.structure.terms:
        if position is not None and set(placed.term.reads) == {position}:
            names.update(placed.term.columns(signals, placed.value).names)
    for j, name in enumerate(current.columns.names):
        if name in names:
            elastic += current.fit.coef[j] * current.columns.values[:, j]
    return signals.with_columns(**{ELASTIC: elastic})


def _screen(current: StructureFit, candidate: Candidate, signals: Signals, spec) -> Screen:
    """Profile the candidate's parameter with every parameter of the model re-profiled: over
    its whole grid at the candidate's first grid value (no state carried over from the model
    without the effect), then from there along the candidate's grid (each walk starts where the
    previous value's ended, following the ridge); test it on the effective sample size of the
    *augmented* model's residual (the current residual still holds the effect, whose
    persistence would inflate tau_int and hide it)."""
    grid = candidate.hyper.grid if candidate.hyper is not None else (None,)
    index = len(current.structure.terms)
    base = current.structure.plus(candidate, grid[0])
    fits = [profile(base, signals, fixed=(index,))]
    for g in grid[1:]:
        trial = fit_structure(fits[-1].structure.at(index, g), signals)
        for i in trial.structure.hypers:
            if i != index:
                trial = descend(trial, i, signals)
        fits.append(trial)
    sse = np.array([f.sse for f in fits])
    signs = np.array([_physical(candidate, f) for f in fits])
    best = int(np.argmin(np.where(signs, sse, np.inf))) if signs.any() else int(np.argmin(sse))
    joint = refine(fits[best], signals)
    q = joint.columns.width - current.columns.width + (candidate.hyper is not None)
    p1 = joint.columns.width + len(joint.structure.hypers)
    n_eff = current.fit.n / residual_tau_int(joint.residual, signals)
    test = NestedTest.of(current.sse, joint.sse, q, p1, n_eff)
    interval = None
    if candidate.hyper is not None:
        interval = profile_interval(np.asarray(grid, dtype=float), sse, n_eff, spec.confidence)
    physical = bool(signs[best]) and _physical(candidate, joint)
    value = joint.structure.terms[index].value
    return Screen(candidate, value, test, interval, physical, n_eff, joint.sse)


def run_loop(signals: Signals, base: LoopBase, spec: LoopSpec, setting: Setting) -> LoopResult:
    """Diagnose, test, confirm and add effects; then say what remains."""
    from threadpoolctl import threadpool_limits

    # hundreds of small least-squares problems: BLAS threads only contend for the cores
    with threadpool_limits(limits=1, user_api="blas"):
        return _run_loop(signals, base, spec, setting)


def _run_loop(signals: Signals, base: LoopBase, spec: LoopSpec, setting: Setting) -> LoopResult:
    candidates = make_candidates(spec.candidate_names(setting), setting)
    held = signals.validation  # the comparison's held-out rows, where before/after are scored
    margins = [base.structure.margins, *(c.margins for c in candidates)]
    signals = signals.trim(max(m[0] for m in margins), max(m[1] for m in margins))
    current = profile(base.structure, signals)
    start = current
    rows, effects = [], []
    remaining = [c for c in candidates if not (c.elastic and setting.position is None)]
    for round_no in range(1, spec.max_effects + 1):
        if not remaining:
            break
        signals = _with_elastic(signals, current, setting.position)
        screened = [_screen(current, c, signals, spec) for c in remaining]
        p_holm = holm([screen.test.p_value for screen in screened])
        held_rmse = current.scores(signals.validation).rmse
        # rank on one sample size for all: each candidate's own n_eff (its residual's) decides
        # significance, but would favour whichever whitens its residual most, not fits best
        n_common = current.fit.n / residual_tau_int(current.residual, signals)
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
            candidate = screened[i].candidate
            trial = profile(current.structure.plus(candidate, screened[i].value), signals)
            rmse = trial.scores(signals.validation).rmse
            change = rmse / held_rmse - 1.0
            round_rows[i] |= {"held-out RMSE": rmse, "held-out change": change}
            if change <= -spec.margin:
                round_rows[i]["added"] = True
                added = (candidate, trial, round_rows[i], screened[i].interval)
                break
        rows.extend(round_rows)
        if added is None:
            break
        candidate, trial, evidence, interval = added
        effects.append(make_effect(candidate, trial, current, signals, interval, evidence,
                                   held_rmse, spec.confidence))  # fmt: skip
        remaining.remove(candidate)
        current = trial
        # only the structure scan decides whether to go on; the full diagnostics come at the end
        strongest = structure_scan(current.residual, signals.train, signals)["eta2"].max()
        if strongest < spec.structure_threshold:
            break
    return finish(spec, signals, base, start, current, effects, pd.DataFrame(rows), held)


def _row(round_no, current: StructureFit, screen: Screen, p_adj: float, n_common, spec) -> dict:
    test = screen.test
    rank = NestedTest.of(current.sse, screen.sse, test.q, 0, n_common)
    passes = p_adj < spec.alpha and test.delta_bic < 0 and screen.identified
    return {
        "round": round_no,
        "candidate": screen.candidate.name,
        "profiled": _profiled(screen.candidate, screen.value, screen.interval),
        # the residual's correlation with the candidate's (nonlinear) features, jointly
        "partial R": float(np.sqrt(max(0.0, 1.0 - screen.sse / current.sse))),
        "F": test.f,
        "n_eff": screen.n_eff,
        "p": test.p_value,
        "p (Holm)": p_adj,
        "ΔBIC": test.delta_bic,
        "ΔBIC (rank)": rank.delta_bic,
        "identified": screen.identified,
        "passes training": bool(passes),
        "held-out RMSE": np.nan,
        "held-out change": np.nan,
        "added": False,
    }


def _profiled(candidate: Candidate, value, interval) -> str:
    if candidate.hyper is None:
        return ""
    return (
        f"{candidate.hyper.name} = {value:.4g} {candidate.hyper.unit} "
        f"[{interval[0]:.4g}, {interval[1]:.4g}]"
    )
