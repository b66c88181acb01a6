"""The loop: fit the base, test every candidate effect, add the best confirmed one, repeat.

See :class:`hmid.loop.config.LoopSpec` for the acceptance rule. Everything is deterministic:
profiled parameters are chosen on fixed grids and fits are least squares.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from hmid.loop.candidates import Candidate, make_candidates
from hmid.loop.config import LoopSpec
from hmid.loop.data import LoopData
from hmid.loop.diagnostics import residual_tau_int, structure_scan
from hmid.loop.result import LoopResult, finish, make_effect
from hmid.loop.statistics import NestedTest, profile_interval
from hmid.loop.structure import (
    Structure,
    StructureFit,
    Term,
    descend,
    parameters,
    refine,
    refit,
)


def _hypers(structure: Structure) -> int:
    return (structure.base.hyper is not None) + sum(
        t.candidate.hyper is not None for t in structure.effects
    )


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


def _screen(current: StructureFit, candidate: Candidate, data, spec, cache) -> Screen:
    """Profile the candidate's parameter with the base's re-profiled at every grid value (the
    base absorbed part of the effect, so its hyperparameter moves once the effect is in; each
    walk starts where the previous grid value's ended, following the ridge), and test it on the
    effective sample size of the *augmented* model's residual: the current residual still holds
    the effect, whose persistence would inflate tau_int and hide it."""
    base = current.structure
    sign = base.base.friction_sign(current.params)
    fits = []
    for g in candidate.grid:
        fits.append(descend(base.plus(Term(candidate, g)), data, cache))
        base = replace(base, base_value=fits[-1].structure.base_value)
    sse = np.array([f.fit.sse for f in fits])
    # a parameter missing from a fit is a column the base already has (merged): not constrained
    signs = np.array(
        [all(sign * f.params.get(k, 1.0) > 0 for k in candidate.positive) for f in fits]
    )
    best = int(np.argmin(np.where(signs, sse, np.inf))) if signs.any() else int(np.argmin(sse))
    joint = fits[best]
    joint = refine(joint, data, cache)
    q = joint.columns.width - current.columns.width + (candidate.hyper is not None)
    p1 = joint.columns.width + _hypers(joint.structure)
    n_eff = current.fit.n / residual_tau_int(joint.residual, data)
    test = NestedTest.of(current.fit.sse, joint.fit.sse, q, p1, n_eff)
    grid = np.array([np.nan if g is None else g for g in candidate.grid], dtype=float)
    interval = profile_interval(grid, sse, n_eff, spec.confidence) if candidate.hyper else None
    physical = bool(signs[best]) and all(
        sign * joint.params.get(k, 1.0) > 0 for k in candidate.positive
    )
    return Screen(candidate, candidate.grid[best], test, interval, physical, n_eff, joint.fit.sse)


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
    current = refit(Structure(spec.base, spec.base.grid[0]), data, cache, full=True)
    start = current
    rows, effects, remaining = [], [], list(candidates)
    for round_no in range(1, spec.max_effects + 1):
        if not remaining:
            break
        screened = [_screen(current, c, data, spec, cache) for c in remaining]
        p_holm = _holm([screen.test.p_value for screen in screened])
        held_rmse = current.held_out(data).rmse
        # rank on one sample size for all: each candidate's own n_eff (its residual's) decides
        # significance, but would favour whichever whitens its residual most, not fits best
        n_common = current.fit.n / residual_tau_int(current.residual, data)
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
            trial = refit(current.structure.plus(Term(candidate, screened[i].value)), data, cache)
            rmse = trial.held_out(data).rmse
            change = rmse / held_rmse - 1.0
            round_rows[i] |= {"held-out RMSE [N]": rmse, "held-out change": change}
            if change <= -spec.margin:
                round_rows[i]["added"] = True
                added = (candidate, trial, round_rows[i], screened[i].interval)
                break
        rows.extend(round_rows)
        if added is None:
            break
        candidate, trial, evidence, interval = added
        tau_int = residual_tau_int(trial.residual, data)
        table = parameters(trial, data, tau_int, spec.confidence, cache)
        base_hyper = [spec.base.hyper[0]] if spec.base.hyper else []
        own = table[~table["parameter"].isin([*current.columns.names, *base_hyper])]
        sign = trial.structure.base.friction_sign(trial.params)
        if candidate.friction and sign < 0:  # shown as friction, whatever the log's convention
            own = own.assign(value=-own["value"], lower=-own["upper"], upper=-own["lower"])
        value = trial.structure.effects[-1].value
        effects.append(make_effect(candidate, own, value, interval, evidence, held_rmse))
        remaining.remove(candidate)
        current = trial
        # only the structure scan decides whether to go on; the full diagnostics come at the end
        strongest = structure_scan(current.residual, data.train, data)["eta2"].max()
        if strongest < spec.structure_threshold:
            break
    return finish(spec, data, start, current, effects, pd.DataFrame(rows), cache)


def _row(round_no, current: StructureFit, screen: Screen, p_adj: float, n_common, spec) -> dict:
    test = screen.test
    rank = NestedTest.of(current.fit.sse, screen.sse, test.q, 0, n_common)
    passes = p_adj < spec.alpha and test.delta_bic < 0 and screen.identified
    return {
        "round": round_no,
        "candidate": screen.candidate.name,
        "profiled": _profiled(screen.candidate, screen.value, screen.interval),
        # the residual's correlation with the candidate's (nonlinear) features, jointly
        "partial R": float(np.sqrt(max(0.0, 1.0 - screen.sse / current.fit.sse))),
        "F": test.f,
        "n_eff": screen.n_eff,
        "p": test.p_value,
        "p (Holm)": p_adj,
        "ΔBIC": test.delta_bic,
        "ΔBIC (rank)": rank.delta_bic,
        "identified": screen.identified,
        "passes training": bool(passes),
        "held-out RMSE [N]": np.nan,
        "held-out change": np.nan,
        "added": False,
    }


def _holm(p: list[float]) -> np.ndarray:
    from statsmodels.stats.multitest import multipletests

    return multipletests(p, method="holm")[1] if p else np.array([])


def _profiled(candidate: Candidate, value, interval) -> str:
    if candidate.hyper is None:
        return ""
    name, unit = candidate.hyper
    return f"{name} = {value:.4g} {unit} [{interval[0]:.4g}, {interval[1]:.4g}]"
