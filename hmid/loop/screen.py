"""One candidate fitted jointly with the current model on the training rows, and its test.

Every profiled parameter is searched afresh for each candidate: the model's own (a relaxation
time) over its whole grid at each of two starts, the candidate's along its whole range, so no fit
inherits a state that the missing effect corrupted (a relaxation time stuck where it absorbed a
viscous friction).

The candidate's own grid is scanned coarsely (about :data:`COARSE` values), then walked from the
best value while the SSE falls and filled in outwards from the edges of its likelihood interval,
so its minimum and its interval are those of the whole grid wherever the profile has one minimum
between coarse values (tested against the whole grid). A timing candidate's every value
transforms the signals and rebuilds every column that reads them: this halves its cost.
A walk follows one ridge of the joint profile; where the model's and the candidate's parameters
have several (a lag's T against a relaxation time), the coarse path may end on another ridge
than the whole grid's path would, as often lower as not.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from hmid.balance import Signals, StructureFit, descend, fit_structure, parameters, profile, refine
from hmid.loop.candidates import Candidate
from hmid.stats import NestedTest, likelihood_interval, residual_tau_int

#: every 4th point of a model's hyperparameter grid (ratio 1.17^4 = 1.9 on the SLS's tau grid),
#: then a walk from the best: each candidate re-profiles the model twice, and this is most of
#: the loop's time
PROFILE_STEP = 4
#: about this many values of a candidate's own grid are scanned before the walk and the fill
COARSE = 8


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
        if hyper is None or self.interval is None:  # an interval wherever there is a hyper
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
    if not positive or candidate.signs_hold({k: fitted.params[k] for k in positive}):
        return True  # an upper bound is never below its estimate: no interval needed
    # with the profiled parameters' sensitivities: a viscous coefficient trades off against a
    # relaxation time, and its interval must say so
    table = parameters(fitted, signals, confidence)
    upper = table.set_index("parameter")["upper"]
    return candidate.signs_hold({k: float(upper[k]) for k in positive})


def screen(current: StructureFit, candidate: Candidate, signals: Signals, confidence) -> Screen:
    """Profile the candidate's parameter over its grid (:func:`along`): the model's parameters
    fully profiled at the grid's first value, then walked from value to value (following the
    ridge); at the best value they are profiled over their whole grids again, and the better of
    the two kept. The test uses the effective sample size of the *augmented* residual (the
    current residual still holds the effect, whose persistence would inflate tau_int and hide
    it)."""
    grid = candidate.hyper.grid if candidate.hyper is not None else (None,)
    index = len(current.structure.terms)
    fits = along(current, candidate, signals)
    best = _best(candidate, fits)
    # the model's parameters are refined where the fit is a profile's (the grid's first value,
    # or a fresh profile at the best): refining them again would only repeat the search
    settled = best == 0
    if best and len(current.structure.hypers):
        fresh = profile(current.structure.plus(candidate, grid[best]), signals, fixed=(index,),
                        step=PROFILE_STEP)  # fmt: skip
        if fresh.sse < fits[best].sse:
            fits[best], settled = fresh, True
    joint = refine(fits[best], signals, fixed=range(index) if settled else ())
    q = joint.columns.width - current.columns.width + (candidate.hyper is not None)
    p1 = joint.columns.width + len(joint.structure.hypers)
    tau_int = residual_tau_int(joint.residual, signals)
    n_eff = current.fit.n / tau_int
    test = NestedTest.of(current.sse, joint.sse, q, p1, n_eff)
    interval = None
    if candidate.hyper is not None:
        _fill(fits, index, signals, n_eff, confidence)
        sse = np.array([fits[j].sse if j in fits else np.inf for j in range(len(grid))])
        # refined at the crossings, around the estimate refined between grid points
        value = joint.structure.terms[-1].value
        assert value is not None  # a profiled term is placed at a value
        estimate = (value, joint.sse)
        interval = likelihood_interval(grid, sse, n_eff, confidence, estimate, candidate.hyper.log)
    collinear = _rank_deficient(joint)
    ok = not collinear and consistent(candidate, joint, signals, confidence)
    return Screen(candidate, joint, test, interval, ok, n_eff, collinear)


def along(current: StructureFit, candidate: Candidate, signals: Signals) -> dict[int, StructureFit]:
    """The joint fit at grid values of the candidate's parameter (by grid index): every
    ``len(grid) // COARSE``-th value and the last, each from the previous one's fit, then a walk
    from the best each way while the SSE falls (every value of a grid of under 2 COARSE)."""
    grid = candidate.hyper.grid if candidate.hyper is not None else (None,)
    index = len(current.structure.terms)
    base = current.structure.plus(candidate, grid[0])
    fits = {0: profile(base, signals, fixed=(index,), step=PROFILE_STEP)}
    step = max(1, len(grid) // COARSE)
    coarse = list(dict.fromkeys((*range(0, len(grid), step), len(grid) - 1)))
    for before, j in itertools.pairwise(coarse):
        fits[j] = _moved(fits[before], index, grid[j], signals)
    best = _best(candidate, fits)
    for direction in (-1, 1):
        j = best + direction
        while 0 <= j < len(grid) and j not in fits:
            fits[j] = _moved(fits[j - direction], index, grid[j], signals)
            if fits[j].sse >= fits[j - direction].sse:
                break
            j += direction
    return fits


def _moved(start: StructureFit, index: int, value: float | None, signals: Signals) -> StructureFit:
    """The joint fit with the candidate at ``value``, the model's parameters walked from
    ``start``'s (the ridge followed)."""
    trial = fit_structure(start.structure.at(index, value), signals)
    for i in trial.structure.hypers:
        if i != index:
            trial = descend(trial, i, signals)
    return trial


def _best(candidate: Candidate, fits: dict[int, StructureFit]) -> int:
    """The grid index of the least SSE, among fits with physical signs if any has them (the
    final check allows for noise)."""
    signs = {j: physical(candidate, f) for j, f in fits.items()}
    pool = [j for j in fits if signs[j]] or list(fits)
    return min(pool, key=lambda j: (fits[j].sse, j))


def _fill(fits: dict, index: int, signals: Signals, n_eff: float, confidence: float) -> None:
    """Grid values outwards from the likelihood interval's edges, each from its inner
    neighbour's fit, until each edge meets a value outside the interval or the grid's end."""
    from scipy import stats

    grid = fits[0].structure.terms[index].term.hyper.grid
    size = len(grid)
    limit = stats.chi2.ppf(confidence, 1)
    while True:
        least = min(f.sse for f in fits.values())
        inside = [j for j, f in fits.items() if n_eff * np.log(f.sse / least) <= limit]
        edges = ((min(inside), -1), (max(inside), 1))
        todo = [(j + d, j) for j, d in edges if 0 <= j + d < size and j + d not in fits]
        if not todo:
            return
        for j, start in todo:
            fits[j] = _moved(fits[start], index, grid[j], signals)


def _rank_deficient(fitted: StructureFit) -> bool:
    """Whether the design's columns are linearly dependent on the fitted rows (scaled, so the
    test does not depend on units)."""
    X = fitted.columns.values[fitted.rows]
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    return bool(np.linalg.matrix_rank(X / scale, tol=1e-9) < X.shape[1])
