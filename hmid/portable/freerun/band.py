"""The band of a free run: what the model does not know, propagated through the simulation.

Two sources, each drawn and run through the free run (:meth:`Simulator.positions`):

* the coefficients' uncertainty: the model's posterior draws where it has them (the relaxation
  times drawn with the rest), else a normal with its coefficients' covariance;
* the model's own error in simulation: a disturbance force on the balance's model side, AR(1)
  with the training residual's RMS and correlation time, times a scale ``s``.

With s = 1 the band is far too narrow (15-44 % coverage of a nominal 90 % on the shipped
rigs): most of the one-step residual is sensor noise and the acceleration's, which the rig's
inertia filters out, while a free run drifts by what the model leaves unexplained at low
frequency. So ``s`` is calibrated, on the training blocks only (:func:`calibrate`): their free
runs, cut to the held-out blocks' length and each started from the measured state, give the
scale at which the band covers the measured position at the nominal level there. The held-out
blocks' coverage, reported, is then an honest check, never the target. A model whose
coefficient band alone covers more than the level gets ``s = 0`` (the band is then wider than
nominal, and says so); one that no scale brings to the level (its draws diverge) says that.

A force is not the only shape of what a model misses. Where friction holds the stage (a stick
band), a small force moves nothing, and the free run's error is a slow drift while it slides:
no scale of a force reaches the level there. So a second disturbance is offered, a drift of
the position itself (a random walk from the block's measured start: an output error whose
spread grows as the square root of the time run), and the training blocks choose between the
two by two-fold cross-calibration (:func:`cross_miss`): the scale is calibrated on half of
them and the coverage checked on the other half, early and late in the blocks, and the shape
whose coverage there misses the level least is kept (the force on a tie: it is the physical
one).

A scale calibrated to the level on a few training blocks covers blocks it was not calibrated on
less than the level: one block more or less moves it, and a band too narrow loses more
coverage than one as much too wide gains. So the level the training blocks are calibrated to
is raised by that loss, measured on them by leaving each out in turn (:func:`held_out_target`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from hmid.balance.kinds import MemoryTerm
from hmid.portable.freerun.integrator import Coefficients, Simulator


def coefficient_draws(model, sim: Simulator, n: int, seed: int) -> list[Coefficients] | None:
    """``n`` draws of the simulator's coefficients from the model's uncertainty: its posterior
    draws where it has them (the relaxation times drawn with the rest), else a normal with its
    coefficients' covariance; None where the file has neither."""
    cr, cl, taus, lags = sim.coefficients()
    n_terms = len(model.terms)
    signs = np.array([t.sign for t in model.terms], dtype=float)
    rng = np.random.default_rng(seed)
    post = posterior_draws(model)
    if post is not None:
        names = [t.name for t in model.terms]
        arms = [t for t in model.terms if isinstance(t, MemoryTerm)]
        tau_names = ["tau"] if len(arms) == 1 else [f"tau_{i + 1}" for i in range(len(arms))]
        if not all(v in post for v in (*names, *tau_names)):
            return None
        flat = {v: np.asarray(post[v], dtype=float).reshape(-1) for v in (*names, *tau_names)}
        pick = rng.choice(len(flat[names[0]]), size=n, replace=False)
        out = []
        for i in pick:
            draw = cr.copy()
            draw[:n_terms] = signs * np.array([flat[v][i] for v in names])
            out.append((draw, cl, np.array([flat[v][i] for v in tau_names]), lags))
        return out
    cov = model.covariance
    if cov is None:
        return None
    cov = (cov + cov.T) / 2  # symmetric to rounding; eigh clips the rounding below zero
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        coef = rng.multivariate_normal(model.coef, cov, size=n, method="eigh")
    out = []
    for row in coef:
        draw = cr.copy()
        draw[:n_terms] = signs * row
        out.append((draw, cl, taus, lags))
    return out


def posterior_draws(model):
    """The model's posterior draws by name (each (chains, draws)), None where it has none: the
    draws it holds in memory as they are (the fit's, in a run: ArviZ, a second's import, is
    the report's), else its file's."""
    if model.draws is not None:
        return model.draws
    return None if model.posterior is None else model.posterior.posterior


def disturbances(model, n: int, draws: int, rng) -> np.ndarray:
    """``draws`` realisations (rows of ``n`` samples) of the force the model leaves unexplained,
    as a disturbance of the free run: AR(1) with the training residual's RMS and integrated
    autocorrelation time tau (phi = (tau - 1) / (tau + 1)); zeros where the file has none."""
    residual = model.document.get("residual") or {}
    sigma, tau = residual.get("rmse"), residual.get("tau_int") or 1.0
    if not sigma:
        return np.zeros((draws, n))
    phi = (tau - 1.0) / (tau + 1.0)
    e = rng.standard_normal((draws, n)) * sigma * np.sqrt(1 - phi**2)
    from scipy.signal import lfilter

    start = rng.standard_normal(draws) * sigma
    return lfilter([1.0], [1.0, -phi], e, axis=1, zi=(phi * start)[:, None])[0]


def drifts(t: np.ndarray, draws: int, rng) -> np.ndarray:
    """``draws`` random walks of the position at the times ``t``, each from 0 at the first,
    with a variance of 1 (position unit)^2 per second: the drift disturbance at scale 1."""
    steps = rng.standard_normal((draws, len(t) - 1)) * np.sqrt(np.diff(t))
    return np.concatenate([np.zeros((draws, 1)), np.cumsum(steps, axis=1)], axis=1)


#: The shapes of disturbance a band can carry (see the module's docstring)
FORCE, DRIFT = "force", "drift"


@dataclass(frozen=True)
class Calibration:
    """The disturbance's shape and scale, and the band's coverage on the training blocks at
    that scale; ``miss``: its two-fold cross-calibrated coverage's distance from the level."""

    scale: float
    coverage: float
    samples: int  # the training samples it was calibrated on
    reachable: bool = True  # False: no scale up to the largest tried reaches the level
    kind: str = FORCE
    miss: float = np.nan
    diverging: float = 0.0  # the share of coefficient draws that diverge on the training blocks
    target: float = np.nan  # the training coverage calibrated to (:func:`held_out_target`)

    def why_not(self) -> str:
        """Why the band is not calibrated, in words ("" where it is)."""
        if self.reachable:
            return ""
        if self.diverging > 0.5:
            return (f"band not calibrated: {100 * self.diverging:.0f} % of the coefficient draws "
                    "diverge on the training blocks (the model is stable near its estimate "
                    "only)")  # fmt: skip
        return (
            "band not calibrated: no disturbance scale reaches the level on the training "
            f"blocks ({100 * self.coverage:.0f} % at the largest tried)"
        )


def quantile_band(runs: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """The central ``level`` band of ``runs`` (draws, samples), numpy's linear quantiles of the
    draws that did not diverge (NaN or inf: left out); NaN bounds where every draw did. One
    sort for every sample (``np.nanquantile`` goes sample by sample)."""
    runs = np.where(np.isfinite(runs), runs, np.nan)
    ordered = np.sort(runs, axis=0)  # NaN last
    valid = np.sum(np.isfinite(runs), axis=0)
    last = np.maximum(valid - 1, 0)[None]
    tail = (1 - level) / 2
    bounds = []
    for q in (tail, 1 - tail):
        position = (valid - 1) * q
        below = np.clip(np.floor(position).astype(int)[None], 0, last)
        low = np.take_along_axis(ordered, below, 0)[0]
        high = np.take_along_axis(ordered, np.minimum(below + 1, last), 0)[0]
        bound = low + (high - low) * (position - below[0])
        bounds.append(np.where(valid > 0, bound, np.nan))
    return bounds[0], bounds[1]


def calibrate(chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]], level: float,
              reach: float = 1e4, target: float | None = None) -> Calibration:  # fmt: skip
    """The scale s of the disturbance at which the ``level`` band covers ``target`` (default:
    ``level``) of the measured position over ``chunks``, each (measured, nominal, coefficient
    deviations, disturbance deviations): the runs of the coefficient draws without disturbance,
    less the nominal run, and of the nominal coefficients under a disturbance of scale 1, less
    the nominal run. Their sum, nominal + C + s D, stands for a draw of both (to first order: a
    free run responds to a small force linearly), so s is found without a run per trial scale.

    The search starts where the disturbance's spread matches the nominal run's error, brackets
    s by factors of 4 up to ``reach`` times that, then halves the bracket's logarithm seven
    times (s to about 1 %)."""
    samples = sum(len(x) for x, *_ in chunks)
    pool, found, goal = _Pool.of(chunks), {}, level if target is None else target

    def coverage(s: float) -> float:  # the search asks some scales twice
        if s not in found:
            found[s] = pool.coverage(level, s)
        return found[s]

    covered = coverage(0.0)
    if covered >= goal:
        return Calibration(0.0, covered, samples)
    start = _matched_scale(chunks)
    low, high = start, start
    if (covered := coverage(start)) < goal:
        while covered < goal:
            if high >= reach * start:
                return Calibration(high, covered, samples, reachable=False)
            low, high = high, high * 4
            covered = coverage(high)
    else:
        while coverage(low) >= goal and low > start / reach:
            high, low = low, low / 4
    for _ in range(7):
        middle = np.sqrt(low * high)
        if coverage(middle) >= goal:
            high = middle
        else:
            low = middle
    return Calibration(high, coverage(high), samples)


def _matched_scale(chunks: list) -> float:
    """The scale at which the disturbance's runs spread as far from the nominal run as the
    measured position does (RMS over the chunks); 1 where either is zero or not finite."""
    error = np.concatenate([x - nominal for x, nominal, _, _ in chunks])
    spread = np.concatenate([d.ravel() for *_, d in chunks])
    error, spread = error[np.isfinite(error)], spread[np.isfinite(spread)]
    if not len(error) or not len(spread):
        return 1.0
    with np.errstate(over="ignore", invalid="ignore"):  # diverged draws: inf, then 1
        ratio = np.sqrt(np.mean(error**2) / np.mean(spread**2)) if np.any(spread) else np.inf
    return float(ratio) if np.isfinite(ratio) and ratio > 0 else 1.0


#: A band's coverage is judged in this many spans of elapsed time (:func:`cross_miss`)
HORIZONS = 4


def cross_miss(chunks: list, level: float) -> float:
    """How far the band misses the level on training blocks it was not calibrated on: the
    scale calibrated on every other chunk, the coverage measured on the rest, both ways, in
    each of :data:`HORIZONS` spans of the time run since the chunk's start; the mean distance
    of those coverages from ``level`` (NaN with fewer than two chunks). Judged by horizon, the
    miss sees a band of the wrong shape (too narrow early and too wide late, or the reverse)
    that a coverage pooled over the chunks would not. A half that no scale brings to the level
    lends the other half its largest scale tried: the shape is judged by what that band covers
    there (a band far too wide misses too), not ruled out by one calm half."""
    if len(chunks) < 2:
        return np.nan
    halves = (chunks[0::2], chunks[1::2])
    miss = []
    for fitted, checked in (halves, halves[::-1]):
        found = calibrate(fitted, level)
        miss.append(np.abs(coverage_by_horizon(checked, level, found.scale) - level))
    return float(np.mean(miss))


def coverage_of(chunks: list, level: float, scale: float) -> float:
    """The share of the measured samples of ``chunks`` inside the band at ``scale``."""
    return _Pool.of(chunks).coverage(level, scale)


def coverage_by_horizon(chunks: list, level: float, scale: float) -> np.ndarray:
    """The band's coverage at ``scale`` in each of :data:`HORIZONS` equal spans of each chunk's
    samples (the first span: the samples nearest the chunk's start)."""
    pool = _Pool.of(chunks)
    inside = np.bincount(pool.span, pool.inside(level, scale), HORIZONS)
    return inside / np.maximum(np.bincount(pool.span, minlength=HORIZONS), 1)


@dataclass(frozen=True)
class _Pool:
    """Chunks side by side (their samples concatenated): a band is a quantile of each sample's
    draws alone, so one pass over the pool is the passes over its chunks, without a call and a
    sort per chunk at every scale the search tries. ``span``: each sample's :data:`HORIZONS`
    span of its own chunk; ``chunk``: the chunk's number."""

    x: np.ndarray
    base: np.ndarray  # the nominal run plus each coefficient draw's deviation
    d: np.ndarray
    span: np.ndarray
    chunk: np.ndarray

    @classmethod
    def of(cls, chunks: list) -> _Pool:
        spans = [np.minimum(np.arange(len(x)) * HORIZONS // len(x), HORIZONS - 1)
                 for x, *_ in chunks]  # fmt: skip
        x, nominal, c, d = (np.concatenate(part, axis=-1) for part in zip(*chunks, strict=True))
        number = np.repeat(np.arange(len(chunks)), [len(x) for x, *_ in chunks])
        with np.errstate(invalid="ignore"):  # a diverged nominal run: inf less inf, read as NaN
            return cls(x, nominal + c, d, np.concatenate(spans), number)

    def coverage(self, level: float, scale: float) -> float:
        return int(np.sum(self.inside(level, scale))) / len(self.x)

    def inside(self, level: float, scale: float) -> np.ndarray:
        """Whether each measured sample lies inside the band at ``scale``: the bounds of
        :func:`quantile_band`, bit for bit, read from the two least and two greatest draws of
        each sample whose draws are all finite (all a band of 4 to 21 draws at 90 % needs: a
        pass over the draws rather than a sort of them)."""
        # nominal + c + scale * d, as every band sums them; a diverged draw's inf times a scale
        # of 0 is NaN, which the band reads as not finite, as it reads the inf
        with np.errstate(invalid="ignore", over="ignore"):
            runs = self.base + scale * self.d
        n = len(runs)
        tail = (1 - level) / 2
        position = np.array([(n - 1) * tail, (n - 1) * (1 - tail)])
        below = np.clip(np.floor(position).astype(int), 0, n - 1)
        if n < 4 or below[0] > 0 or below[1] < n - 2:
            lower, upper = quantile_band(runs, level)
            return (lower <= self.x) & (self.x <= upper)
        finite = np.all(np.isfinite(runs), axis=0)
        ordered = _extremes(runs[:, finite])  # the least, the next, the next greatest, greatest
        low = [ordered[0], ordered[2] if below[1] == n - 2 else ordered[3]]
        high = [ordered[1], ordered[3]]
        lower, upper = np.full(len(self.x), np.nan), np.full(len(self.x), np.nan)
        lower[finite], upper[finite] = (
            low[i] + (high[i] - low[i]) * (position[i] - below[i]) for i in (0, 1)
        )
        if not np.all(finite):
            lower[~finite], upper[~finite] = quantile_band(runs[:, ~finite], level)
        return (lower <= self.x) & (self.x <= upper)


def _extremes(runs: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per column of ``runs`` (at least two rows): the least, the second least, the second
    greatest and the greatest value (the entries of a sort, ties included)."""
    least, next_least = np.minimum(runs[0], runs[1]), np.maximum(runs[0], runs[1])
    greatest, next_greatest = next_least.copy(), least.copy()
    for row in runs[2:]:
        next_least = np.minimum(next_least, np.maximum(least, row))
        least = np.minimum(least, row)
        next_greatest = np.maximum(next_greatest, np.minimum(greatest, row))
        greatest = np.maximum(greatest, row)
    return least, next_least, next_greatest, greatest


def choose(forced: list, drifted: list, level: float) -> Calibration:
    """The disturbance of the two shapes whose band, calibrated on half of the training
    chunks, covers the other half nearest the level (:func:`cross_miss`); the force on
    a tie or where there are too few chunks to tell, unless no scale of it reaches the level.
    Its scale is then calibrated to the level raised by what a left-out chunk misses
    (:func:`held_out_target`; the level itself with fewer than three chunks, or where the
    coefficient draws alone cover it)."""
    force = replace(calibrate(forced, level), miss=cross_miss(forced, level))
    drift = replace(calibrate(drifted, level), kind=DRIFT, miss=cross_miss(drifted, level))
    if not force.reachable:
        chosen, pieces = (drift, drifted) if drift.reachable else (force, forced)
    elif np.isfinite(drift.miss) and drift.miss < force.miss:
        chosen, pieces = drift, drifted
    else:
        chosen, pieces = force, forced
    if not chosen.reachable or chosen.scale == 0 or len(pieces) < 3:
        return replace(chosen, target=level)
    target = held_out_target(pieces, level, chosen.scale)
    raised = calibrate(pieces, level, target=target) if target > level else chosen
    if not raised.reachable:  # the raised target is out of reach: the level's own scale
        return replace(chosen, target=level)
    return replace(chosen, scale=raised.scale, coverage=raised.coverage, target=target)


#: The scales at which :func:`held_out_target` reads every chunk's coverage: factors of 2^(1/4)
#: about the calibrated scale, up to 8 either way (and 0)
GRID = np.concatenate([[0.0], 2.0 ** (np.arange(-12, 13) / 4)])


def held_out_target(chunks: list, level: float, scale: float, highest: float = 0.99) -> float:
    """The training coverage to calibrate the band to, so that it covers ``level`` of samples
    it was not calibrated on: the least target (in steps of a quarter point, up to ``highest``)
    at which a band calibrated on every chunk but one covers that one at ``level`` or more,
    pooled over the chunks (leave one out). A scale fitted to few chunks misses the next one
    more often than it over-covers it (coverage saturates at 100 %, and falls fast below the
    level), so a band calibrated to the level on its own training blocks covers held-out ones
    less: over 60 simulated data sets of the linear stage, 84 % for a nominal 90 %.

    Every chunk's coverage is read once at each of :data:`GRID` times ``scale``, and each
    leave-one-out calibration is the crossing of the others' coverage there (interpolated
    between the two scales about it; the largest where none reaches): one pass over the
    samples per scale, not a search per chunk and target."""
    pool = _Pool.of(chunks)
    n = len(chunks)
    covered = np.stack([np.bincount(pool.chunk, pool.inside(level, scale * g), n) for g in GRID])
    samples = np.bincount(pool.chunk, minlength=n).astype(float)
    # (scales, chunks): the coverage of all the chunks but each
    rest = (covered.sum(axis=1, keepdims=True) - covered) / np.maximum(samples.sum() - samples, 1)
    for target in np.arange(level, highest + 1e-9, 0.0025):
        if _left_out(covered, rest, target) >= level * samples.sum():
            return round(float(target), 4)
    return highest


def _left_out(covered: np.ndarray, rest: np.ndarray, target: float) -> float:
    """The samples each chunk has covered (``covered``: per scale and chunk) at the scale where
    the other chunks' coverage (``rest``) first reaches ``target``, interpolated between the
    two scales about that crossing (the largest where none reaches it), summed over chunks."""
    chunk = np.arange(covered.shape[1])
    reached = rest >= target
    ever = reached.any(axis=0)
    first = np.where(ever, reached.argmax(axis=0), len(rest) - 1)
    below = np.maximum(first - 1, 0)
    low, high = rest[below, chunk], rest[first, chunk]
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.clip(np.where(ever & (high > low), (target - low) / (high - low), 1.0), 0, 1)
    return float(np.sum(covered[below, chunk] * (1 - share) + covered[first, chunk] * share))
