"""The loop: take a fitted model, test every candidate effect, add the best selected one, repeat.

See :class:`hmid.loop.config.LoopSpec` for the rule and the three roles of rows. The base is any
fitted model of the experiment: its own predictions are the "before", and its terms (the
polynomial's monomials, the SLS's springs and arm, SINDy's selected terms, the declared balance)
are refitted by least squares with each candidate added. Profiled parameters are chosen on fixed
grids, fits are least squares, and the bootstrap draws from the experiment's seed: the same data
and config give the same result.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from threadpoolctl import threadpool_limits

from hmid.balance import Signals, Structure, StructureFit, parameters, profile
from hmid.balance.prepare import without_stopped
from hmid.families.base import FitData, Fitted
from hmid.loop.candidates import ELASTIC, STIFFNESS, Friction, Setting, level, make_candidates
from hmid.loop.config import LoopSpec
from hmid.loop.confounds import rivals, separating
from hmid.loop.decision import Decision
from hmid.loop.declared import (
    LEVEL,
    Corrections,
    decide,
    known_values,
    level_test,
    motion_test,
    testable,
    value_tests,
)
from hmid.loop.diagnostics import pattern_scan
from hmid.loop.parallel import screen_round
from hmid.loop.result import Alternative, LoopResult, added_effect, finish, own_parameters
from hmid.loop.screen import PROFILE_STEP, Screen
from hmid.loop.selection import Folds, change, out_of_fold
from hmid.metrics import score
from hmid.stats import NestedTest, block_resamples, holm, residual_tau_int


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


def with_elastic(signals: Signals, current: StructureFit, position: str | None) -> Signals:
    """``signals`` with the current model's elastic force (its terms that read the position
    alone, at their fitted coefficients: what a stiffness drift scales) and its derivative in
    the position (what a creeping rest length shifts)."""
    if position is None:
        return signals
    elastic = [p for p in current.structure.terms if set(p.term.reads) == {position}]

    def force(seen: Signals) -> np.ndarray:
        names: set[str] = set()
        for placed in elastic:
            names.update(placed.term.columns(seen, placed.value).names)
        columns = current.structure.columns(seen)
        keep = [j for j, name in enumerate(columns.names) if name in names]
        return columns.values[:, keep] @ current.fit.coef[keep]

    h = 1e-3 * (float(np.ptp(signals[position])) or 1.0)
    shifted = [signals.with_columns(**{position: signals[position] + s}) for s in (h, -h)]
    stiffness = (force(shifted[0]) - force(shifted[1])) / (2 * h)
    return signals.with_columns(**{ELASTIC: force(signals), STIFFNESS: stiffness})


def run_loop(
    signals: Signals,
    base: LoopBase,
    spec: LoopSpec,
    setting: Setting,
    seed: int = 0,
    *,
    across_logs: bool = False,
    rig=None,
    low_speed: float | None = None,
) -> LoopResult:
    """Diagnose, test, select and add effects; then say what remains. ``across_logs``: the
    held-out rows are whole logs, and selection also leaves every training log out whole
    (the stricter of the two cross-validations decides). ``rig``: its declared known values
    and motion are tested as hypotheses (:mod:`hmid.loop.declared`). ``low_speed``: the
    deadband of the low-speed rule where the rows keep stopped motion; once the loop adds
    friction to a rig that declared none, its final refit leaves those rows out (static
    friction is indeterminate there, and a Coulomb level fitted on them reads low)."""
    # thousands of small least-squares problems: BLAS threads only contend for the cores
    with threadpool_limits(limits=1, user_api="blas"):
        return _run_loop(signals, base, spec, setting, seed, across_logs, rig, low_speed)


def _run_loop(signals, base: LoopBase, spec: LoopSpec, setting: Setting, seed,
              across_logs=False, rig=None, low_speed=None) -> LoopResult:  # fmt: skip
    clock = _Clock()
    setting = replace(setting, dt=signals.dt)  # timing grids follow the sample rate
    held = signals.validation  # the comparison's held-out rows: reported on, never decided on
    candidates, signals, refit, start = _prepared(signals, base, spec, setting)
    # the rig's known values are hypotheses: a correction found is kept in the base, so that
    # no candidate can be credited with it
    level_known = setting.known_level if refit is not None else None
    start, findings = _declared(rig, base, start, signals, held, setting, spec, level_known)
    current = start
    folds = Folds.of(signals, spec.folds, spec.block_s)
    # the same blocks dealt by log: what a split that holds out whole logs asks of an addition
    by_log = Folds.by_log(signals, spec.block_s) if across_logs else None
    counts = block_resamples(spec.draws, folds.blocks, seed)
    signals = with_elastic(signals, current, setting.position)
    has_elastic = bool(np.any(signals[ELASTIC])) if ELASTIC in signals else False
    remaining = [c for c in candidates if has_elastic or not c.elastic]
    decisions: list[Decision] = []
    effects, steps, friction_added = [], [], False
    part = "setting up"  # what the clock's next lap timed
    for round_no in range(1, spec.max_effects + 1):
        if round_no > 1:  # the model changed: its elastic force with it
            signals = with_elastic(signals, current, setting.position)
        clock.lap(part)
        screened = screen_round(current, remaining, signals, spec.confidence)
        clock.lap(f"round {round_no}: screening {len(remaining)} candidates", len(remaining))
        part = f"round {round_no}: selection"
        screened = [s for s in screened if not s.adds_nothing]
        if not screened:
            break
        chosen = _select(round_no, current, screened, signals, (folds, by_log), counts, spec)
        decisions.extend(chosen.decisions)
        if chosen.best is None:
            break
        added = screened[chosen.best]
        trial = profile(added.joint.structure, signals)  # every parameter afresh, jointly
        effects.append(added_effect(added, trial, current, signals, chosen.decisions[chosen.best],
                                   folds, spec.confidence, chosen.alternatives))  # fmt: skip
        remaining.remove(added.candidate)
        friction_added = friction_added or isinstance(added.candidate, Friction)
        current = trial
        part = f"round {round_no}: selection, adding its effect"
        steps.append((effects[-1].name, current.scores(held)))  # reported, never decided on
        # only the pattern scan decides whether to go on; the full diagnostics come at the end
        strongest = pattern_scan(current.residual, signals.train, signals)["eta2"].max()
        if strongest < spec.structure_threshold:
            break
    refitted = friction_added and low_speed is not None and not setting.declared
    if refitted:
        current = profile(current.structure, without_stopped(signals, low_speed))
    clock.lap(part)
    result = finish(spec, signals, base, start, current, effects, decisions, held, steps,
                    held_out="logs" if across_logs else "rows",
                    fitted_level=setting.fitted_level if refit is not None else None,
                    findings=findings)  # fmt: skip
    clock.lap("diagnostics and verdict")
    if refitted:
        result = _refitted_without_stopped(result, low_speed)
    return replace(result, costs=clock.laps)


def _prepared(signals, base: LoopBase, spec: LoopSpec, setting: Setting):
    """The candidates, the signals trimmed to every structure's margins, the Coulomb level to
    refit (None where the rig has none) and the base fitted with it. The level is refitted
    with the base: a free-fall fit absorbs any other friction law, and its level change would
    otherwise be the cheapest explanation of every one."""
    candidates = make_candidates(spec.candidate_names(setting), setting)
    margins = [base.structure.margins, *(c.margins for c in candidates)]
    signals = signals.trim(max(m[0] for m in margins), max(m[1] for m in margins))
    refit = level(setting)
    structure = base.structure if refit is None else base.structure.plus(refit)
    # every 4th relaxation time, then a walk (as in each screen): the base's profile is smooth
    return candidates, signals, refit, profile(structure, signals, step=PROFILE_STEP)


def _refitted_without_stopped(result: LoopResult, low_speed: float) -> LoopResult:
    """The result of a final refit without the stopped rows: each added effect's table as
    that refit has it, and a note that says why."""
    note = (
        "friction was added to a rig that declares none: the final model is refitted "
        f"without the rows of stopped motion (|v| < {low_speed:g} m/s, as "
        "fit.exclude_stuck: true leaves out), where static friction is indeterminate"
    )
    effects = tuple(_as_final(e, result.final_parameters) for e in result.effects)
    return replace(result, effects=effects, notes=(*result.notes, note))


def _as_final(effect, final):
    """``effect`` with its parameters' values and intervals from the final refit (``final``:
    the final model's table), where that has them."""
    ours = final[final["part"] == effect.name].set_index("parameter")
    table = effect.parameters.copy()
    for i, name in enumerate(table["parameter"]):
        if name in ours.index:
            for column in ("value", "std. error", "lower", "upper"):
                table.loc[i, column] = ours.loc[name, column]
    return replace(effect, parameters=table)


def _declared(rig, base: LoopBase, start: StructureFit, signals, held, setting, spec,
              level_known: str | None):  # fmt: skip
    """The base with the corrections of the rig's known values where any is found (else
    ``start`` itself), and the findings: the declared Coulomb level's refit (dFc, where the base
    refits ``level_known``), those corrections and the motion equation's mass, one family
    (:func:`hmid.loop.declared.decide`: Holm over the run's tests at the loop's ``alpha``), all
    tested on one fit: the base with every testable correction."""
    motion = motion_test(rig, signals, spec.confidence) if rig is not None else None
    known = testable(known_values(rig, signals), start, signals) if rig is not None else ()
    unit = signals.unit("target")
    before = score(signals.target[held], base.prediction[held], "one-step")
    trial = start
    if known:
        trial = profile(start.structure.plus(Corrections(known)), signals, step=PROFILE_STEP)
    table = parameters(trial, signals, spec.confidence)
    level = _level(table, level_known, unit, (before, trial.scores(held)), setting, spec)
    values = value_tests(known, table, setting.position, (before, trial.scores(held)), unit)
    found = decide([t for t in (level, *values, motion) if t is not None], spec.alpha)
    corrected = any(f.parameter != LEVEL and f.refitted for f in found)
    if known and not corrected and any(f.parameter == LEVEL for f in found):
        # the level as the base without corrections has it (the family judged the joint fit)
        said = _level(parameters(start, signals, spec.confidence), level_known, unit,
                      (before, start.scores(held)), setting, spec)  # fmt: skip
        found = tuple(replace(f, message=said.message + f.message[len(level.message):])
                      if f.parameter == LEVEL else f for f in found)  # fmt: skip
    return (trial if corrected else start), found


def _level(table, known: str | None, unit: str, scores, setting, spec):
    """The declared Coulomb level's test (None where the base does not refit it)."""
    if known is None:
        return None
    return level_test(table, known, unit, scores, setting.known_se, spec.confidence)


@dataclass(frozen=True)
class _Round:
    """One round's decisions, the one to add (its index; None: none was selected) and its
    indistinguishable rivals."""

    decisions: tuple[Decision, ...]
    best: int | None
    alternatives: tuple[Alternative, ...] = ()


def _select(round_no, current: StructureFit, screened: list[Screen], signals, both, counts,
            spec: LoopSpec) -> _Round:  # fmt: skip
    """Test every screened candidate on the training rows, cross-validate those that pass
    (``both``: the time-block folds, and the folds by log or None), and pick the one to add:
    of those selected, the lowest ΔBIC on a common sample size."""
    folds, by_log = both
    p_holm = holm([s.test.p_value for s in screened])
    # rank on one sample size for all: each candidate's own n_eff (its residual's) decides
    # significance, but would favour whichever whitens its residual most, not fits best
    n_common = current.fit.n / residual_tau_int(current.residual, signals)
    decisions = [
        _tested(round_no, current, s, p, n_common, spec)
        for s, p in zip(screened, p_holm, strict=True)
    ]
    before = out_of_fold(current.structure, signals, folds)
    before_logs = None if by_log is None else out_of_fold(current.structure, signals, by_log)
    oof = {}
    for i, d in enumerate(decisions):
        if d.passes_training:
            oof[i] = out_of_fold(screened[i].joint.structure, signals, folds)
            cv = change(before, oof[i], folds, counts, spec.confidence)
            decisions[i] = replace(d, cv_change=cv.change, cv_upper=cv.upper,
                                   selected=cv.better(spec.margin))  # fmt: skip
            if by_log is not None and before_logs is not None:  # the stricter wins: better
                # within logs and across them
                across = out_of_fold(screened[i].joint.structure, signals, by_log)
                cv = change(before_logs, across, by_log, counts, spec.confidence)
                decisions[i] = replace(
                    decisions[i], cv_across=cv.change, cv_across_upper=cv.upper,
                    selected=decisions[i].selected and cv.better(spec.margin),
                )  # fmt: skip
    selected = [i for i in oof if decisions[i].selected]
    if not selected:
        return _Round(tuple(decisions), None)
    # BIC on one sample size ranks the selected: of two that fit alike, the simpler
    best = min(selected, key=lambda i: decisions[i].delta_bic_common)
    decisions[best] = replace(decisions[best], added=True)
    alternatives = _alternatives(best, screened, oof, decisions, signals, folds, counts, spec,
                                 current.columns.names)  # fmt: skip
    return _Round(tuple(decisions), best, alternatives)


class _Clock:
    """Wall seconds of the loop's parts, as they end (reported: what a candidate, a round
    cost)."""

    def __init__(self) -> None:
        self.laps: tuple[tuple[str, float, int], ...] = ()
        self._start = time.perf_counter()

    def lap(self, part: str, candidates: int = 0) -> None:
        now = time.perf_counter()
        self.laps += ((part, now - self._start, candidates),)
        self._start = now


def _alternatives(best, screened, oof, decisions, signals, folds, counts, spec, model) -> tuple:
    """Rival physics that cross-validates not clearly worse than the best: indistinguishable.
    Each rival's comparison with the best goes into its entry of ``decisions``."""
    chosen = screened[best].candidate
    out = []
    for i in oof:
        if screened[i].candidate not in rivals(chosen, [screened[i].candidate]):
            continue
        gap = change(oof[best], oof[i], folds, counts, spec.confidence)
        decisions[i] = replace(decisions[i], vs_added=gap.change)
        if gap.lower > 0:  # clearly worse, even at the bootstrap's lower bound
            continue
        decisions[i] = replace(decisions[i], indistinguishable=True)
        s: Screen = screened[i]
        out.append(Alternative(
            s.candidate.name, s.candidate.title, s.candidate.physics,
            own_parameters(s.candidate, s.joint, s.interval, signals, spec.confidence, model),
            gap.change, separating(chosen, s.candidate, signals),
        ))  # fmt: skip
    return tuple(sorted(out, key=lambda a: a.gap))


def _tested(round_no, current: StructureFit, s: Screen, p_adj: float, n_common, spec) -> Decision:
    """A candidate's nested test on the training rows, before any cross-validation."""
    test = s.test
    rank = NestedTest.of(current.sse, s.joint.sse, test.q, 0, n_common)
    passes = p_adj < spec.alpha and test.delta_bic < 0 and s.identified
    return Decision(
        round=round_no,
        candidate=s.candidate.name,
        profiled=s.profiled(),
        # the residual's correlation with the candidate's (nonlinear) features, jointly
        partial_r=float(np.sqrt(max(0.0, 1.0 - s.joint.sse / current.sse))),
        f=test.f,
        n_eff=s.n_eff,
        p=test.p_value,
        p_holm=p_adj,
        delta_bic=test.delta_bic,
        delta_bic_common=rank.delta_bic,
        identified=s.identified,
        passes_training=bool(passes),
    )
