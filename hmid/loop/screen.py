"""One candidate fitted jointly with the current model on the training rows, and its test.

Every profiled parameter is searched afresh for each candidate: the model's own (a relaxation
time) over its whole grid at each of two starts, the candidate's along its whole grid, so no fit
inherits a state that the missing effect corrupted (a relaxation time stuck where it absorbed a
viscous friction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hmid.balance import Signals, StructureFit, descend, parameters, profile, refine
from hmid.balance import fit as fit_structure
from hmid.balance.statistics import profile_interval, residual_tau_int
from hmid.loop.candidates import Candidate
from hmid.loop.statistics import NestedTest

#: every 4th point of a model's hyperparameter grid (ratio 1.17^4 = 1.9 on the SLS's tau grid),
#: then a walk from the best: each candidate re-profiles the model twice, and this is most of
#: the loop's time
PROFILE_STEP = 4


@dataclass(frozen=True)
class Screen:
    """One candidate tested against the current model in one round."""

    candidate: Candidate
    joint: StructureFit  # the model with the candidate, profiled, on the training rows
    test: NestedTest  # on the augmented residual's n_eff
    interval: tuple[float, float] | None  # profile-likelihood interval of its parameter
    physical: bool  # its sign-fixed parameters are consistent with their physical sign
    n_eff: float
    collinear: bool = False  # its columns and the model's are linearly dependent

    @property
    def value(self) -> float | None:
        return self.joint.structure.terms[-1].value

    @property
    def on_edge(self) -> bool:
        hyper = self.candidate.hyper
        return hyper is not None and self.value in (hyper.grid[0], hyper.grid[-1])

    @property
    def identified(self) -> bool:
        return self.physical and not self.collinear and self.candidate.identified(self.value)

    @property
    def adds_nothing(self) -> bool:
        return self.test.q == 0

    def profiled(self) -> str:
        """Its profiled parameter with interval, and whether the grid's edge holds it."""
        hyper = self.candidate.hyper
        if hyper is None:
            return ""
        low, high = self.interval
        edge = " (grid edge)" if self.on_edge else ""
        return f"{hyper.name} = {self.value:.4g} {hyper.unit} [{low:.4g}, {high:.4g}]{edge}"


def physical(candidate: Candidate, fitted: StructureFit) -> bool:
    # a parameter missing from a fit is a column the model already has (merged): not constrained
    return all(fitted.params.get(k, 1.0) > 0 for k in candidate.positive)


def consistent(candidate: Candidate, fitted: StructureFit, signals, confidence) -> bool:
    """Its sign-fixed parameters are not all of their interval on the wrong side of zero: a
    coefficient whose truth is zero (no drag retracting) is estimated just below it half the
    time, and that is no evidence against the physics."""
    positive = [k for k in candidate.positive if k in fitted.params]
    if not positive:
        return True
    # with the profiled parameters' sensitivities: a viscous coefficient trades off against a
    # relaxation time, and its interval must say so
    table = parameters(fitted, signals, confidence)
    upper = table.set_index("parameter")["upper"]
    return candidate.signs_hold({k: float(upper[k]) for k in positive})


def screen(current: StructureFit, candidate: Candidate, signals: Signals, confidence) -> Screen:
    """Profile the candidate's parameter over its grid: the model's parameters fully profiled
    at the grid's first value, then walked from value to value (following the ridge); at the
    best value they are profiled over their whole grids again, and the better of the two kept.
    The test uses the effective sample size of the *augmented* residual (the current residual
    still holds the effect, whose persistence would inflate tau_int and hide it)."""
    grid = candidate.hyper.grid if candidate.hyper is not None else (None,)
    index = len(current.structure.terms)
    base = current.structure.plus(candidate, grid[0])
    fits = [profile(base, signals, fixed=(index,), step=PROFILE_STEP)]
    for g in grid[1:]:
        trial = fit_structure(fits[-1].structure.at(index, g), signals)
        for i in trial.structure.hypers:
            if i != index:
                trial = descend(trial, i, signals)
        fits.append(trial)
    sse = np.array([f.sse for f in fits])
    # prefer grid values whose fit has physical signs; the final check allows for noise
    signs = np.array([physical(candidate, f) for f in fits])
    best = int(np.argmin(np.where(signs, sse, np.inf))) if signs.any() else int(np.argmin(sse))
    if best and len(current.structure.hypers):
        fresh = profile(current.structure.plus(candidate, grid[best]), signals, fixed=(index,),
                        step=PROFILE_STEP)  # fmt: skip
        if fresh.sse < fits[best].sse:
            fits[best], sse[best] = fresh, fresh.sse
    joint = refine(fits[best], signals)
    q = joint.columns.width - current.columns.width + (candidate.hyper is not None)
    p1 = joint.columns.width + len(joint.structure.hypers)
    tau_int = residual_tau_int(joint.residual, signals)
    n_eff = current.fit.n / tau_int
    test = NestedTest.of(current.sse, joint.sse, q, p1, n_eff)
    interval = None
    if candidate.hyper is not None:
        interval = profile_interval(np.asarray(grid, dtype=float), sse, n_eff, confidence)
    collinear = _rank_deficient(joint)
    ok = not collinear and consistent(candidate, joint, signals, confidence)
    return Screen(candidate, joint, test, interval, ok, n_eff, collinear)


def _rank_deficient(fitted: StructureFit) -> bool:
    """Whether the design's columns are linearly dependent on the fitted rows (scaled, so the
    test does not depend on units)."""
    X = fitted.columns.values[fitted.rows]
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    return bool(np.linalg.matrix_rank(X / scale, tol=1e-9) < X.shape[1])
