"""Sparse regression on blocks of rows: pysindy's STLSQ, a cross-validated threshold, bagging.

Every least-squares problem here (a fold's training rows, a bootstrap resample) is a weighted
union of *blocks* of consecutive rows. For each block the QR factor ``R_b`` of ``[Z_b | y_b]`` is
computed once; the problem on a union with weights ``w_b`` is then the one on the stacked
``sqrt(w_b) R_b``, re-factored to a ``(p + 1) x (p + 1)`` triangle ``R``. Because
``|y - Z c|^2 = |R[:, p] - R[:, :p] c|^2`` for every ``c``, pysindy's STLSQ (ridge, thresholding
and the unbiasing refit all depend on the rows only through these sums) returns exactly the
coefficients it would on the rows themselves, at a cost independent of the number of rows: a
30 000-row fit becomes a 17-row one, and a path of thresholds over folds plus a 50-model
ensemble takes about a second on one core.

Threshold rule (training rows only): K folds of contiguous blocks in time order; for each
threshold on a log-spaced path, STLSQ on K - 1 folds and the mean squared error on the left-out
fold; the chosen threshold is the *largest* whose mean CV error is within one standard error of
the smallest (the one-standard-error rule, which prefers the sparser of models that predict
equally well), or the minimiser itself with ``rule="min"``. The rule really picks a *support*
(the set of terms a fit on all training rows keeps there); every threshold in the run of path
points around it with the same support gives the same model, and the threshold used is the
geometric middle of that run. The edge of the run (where the 1-SE rule lands whenever the error
is flat) sits just below the weakest kept term, and the bootstrap there would keep or drop that
term by a coin flip.

Ensemble: a blocked bootstrap (blocks drawn with replacement from a ``numpy.random.Generator``
seeded explicitly; NumPy's global random state is never read or written), STLSQ at the chosen
threshold on each resample. pysindy's ``EnsembleOptimizer`` is not used: it samples rows
independently (wrong for autocorrelated rows) from the global random state.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.linalg import lapack


@dataclass(frozen=True)
class BlockStats:
    """Per-block triangular factors of ``[Z | y]`` (``r``: blocks x (p+1) x (p+1)) and sizes."""

    r: np.ndarray
    rows: np.ndarray

    @property
    def n_blocks(self) -> int:
        return len(self.rows)

    @property
    def n_features(self) -> int:
        return self.r.shape[1] - 1


def block_stats(Z: np.ndarray, y: np.ndarray, blocks: np.ndarray) -> BlockStats:
    """Factors of each block; ``blocks`` holds consecutive block numbers 0, 1, ... per row."""
    p1 = Z.shape[1] + 1
    full = np.column_stack([Z, y])
    starts = np.flatnonzero(np.r_[True, blocks[1:] != blocks[:-1]])
    ends = np.r_[starts[1:], len(blocks)]
    r = np.zeros((len(starts), p1, p1))
    for b, (i, j) in enumerate(zip(starts, ends, strict=True)):
        # LAPACK's QR itself (numpy's qr(mode="r") calls the same routine): a third of its
        # cost is numpy's wrapping, paid once per block
        rows = min(j - i, p1)
        r[b, :rows] = lapack.dgeqrf(full[i:j])[0][:rows]
    below = np.tril_indices(p1, -1)
    r[:, below[0], below[1]] = 0.0  # below the diagonal: LAPACK's reflectors, not R
    return BlockStats(r, ends - starts)


def combine(stats: BlockStats, weights: np.ndarray) -> np.ndarray:
    """The ``(p+1) x (p+1)`` factor of the blocks stacked with (integer or real) ``weights``."""
    use = np.flatnonzero(weights > 0)
    stacked = (np.sqrt(weights[use])[:, None, None] * stats.r[use]).reshape(-1, stats.r.shape[2])
    # numpy's stubs type every mode's result as (Q, R); mode="r" returns R alone
    factor: np.ndarray = np.linalg.qr(stacked, mode="r")  # type: ignore[assignment]
    out = np.zeros((stats.r.shape[2], stats.r.shape[2]))
    out[: factor.shape[0]] = factor
    return out


def stlsq(
    R: np.ndarray,
    threshold: float,
    alpha: float = 0.0,
    max_iter: int = 20,
    keep: np.ndarray | None = None,
) -> np.ndarray:
    """STLSQ (with its unbiasing refit) on the compressed problem ``R``; ``(p,)``."""
    import sklearn

    from hmid.models.sindy._stlsq import KeepSTLSQ  # pysindy: imported where a fit needs it

    p = R.shape[1] - 1
    optimizer = KeepSTLSQ(threshold=threshold, alpha=alpha, max_iter=max_iter, keep=keep)
    # the inputs are checked once upstream: skip sklearn's per-call validation (a third of the
    # cost of a 17-column fit)
    with (
        warnings.catch_warnings(),
        sklearn.config_context(assume_finite=True, skip_parameter_validation=True),
    ):
        # "eliminated all coefficients" / "did not converge": both visible in the result
        warnings.simplefilter("ignore")
        optimizer.fit(R[:, :p], R[:, p])
    return np.asarray(optimizer.coef_, dtype=float).reshape(p)


def sse(R: np.ndarray, coef: np.ndarray) -> float:
    """Sum of squared residuals of ``coef`` on the rows that ``R`` compresses."""
    p = R.shape[1] - 1
    return float(np.sum((R[:, :p] @ coef - R[:, p]) ** 2))


@dataclass(frozen=True)
class ThresholdPath:
    """Cross-validation along a threshold path and the chosen threshold."""

    thresholds: np.ndarray
    cv_mse: np.ndarray  # mean over folds (normalised target: a fraction of var(F_m))
    cv_se: np.ndarray  # standard error of that mean
    n_terms: np.ndarray  # terms kept by a fit on all training rows
    supports: np.ndarray  # those terms (points x p, boolean)
    chosen: float  # the threshold used: middle of the run with the rule's support
    plateau: tuple[float, float]  # path thresholds that give the same support
    rule: str
    folds: int

    @property
    def bound(self) -> float:
        """The one-standard-error rule's bound on the mean CV error."""
        best = int(np.argmin(self.cv_mse))
        return float(self.cv_mse[best] + self.cv_se[best])

    def table(self) -> pd.DataFrame:
        return pd.DataFrame(
            {
                "threshold": self.thresholds,
                "cv mse / var(F_m)": self.cv_mse,
                "std. error": self.cv_se,
                "terms": self.n_terms,
                "chosen support": (self.thresholds >= self.plateau[0])
                & (self.thresholds <= self.plateau[1]),
            }
        )


def fold_of_blocks(n_blocks: int, folds: int) -> np.ndarray:
    """Fold number of each block: ``folds`` contiguous runs of blocks in time order."""
    return np.concatenate(
        [np.full(len(part), k) for k, part in enumerate(np.array_split(np.arange(n_blocks), folds))]
    )


def threshold_path(
    stats: BlockStats,
    *,
    points: int = 30,
    smallest: float = 1e-3,
    folds: int = 5,
    rule: str = "one_se",
    alpha: float = 0.0,
    max_iter: int = 20,
    keep: np.ndarray | None = None,
) -> ThresholdPath:
    """Choose the STLSQ threshold by blocked K-fold CV (see the module docstring)."""
    full = combine(stats, np.ones(stats.n_blocks))
    p = stats.n_features
    ols = np.linalg.lstsq(full[:, :p], full[:, p], rcond=None)[0]
    largest = max(float(np.max(np.abs(ols))), 10 * smallest)
    thresholds = np.geomspace(smallest, largest, points)
    fold = fold_of_blocks(stats.n_blocks, folds)
    errors = np.zeros((points, folds))
    for k in range(folds):
        train = combine(stats, (fold != k).astype(float))
        test = combine(stats, (fold == k).astype(float))
        n_test = float(stats.rows[fold == k].sum())
        for i, threshold in enumerate(thresholds):
            errors[i, k] = sse(test, stlsq(train, threshold, alpha, max_iter, keep)) / n_test
    mse = errors.mean(axis=1)
    se = errors.std(axis=1, ddof=1) / np.sqrt(folds)
    best = int(np.argmin(mse))
    if rule == "one_se":
        chosen = int(np.flatnonzero(mse <= mse[best] + se[best]).max())
    else:
        chosen = best
    supports = [stlsq(full, t, alpha, max_iter, keep) != 0 for t in thresholds]
    low = high = chosen
    while low > 0 and np.array_equal(supports[low - 1], supports[chosen]):
        low -= 1
    while high < points - 1 and np.array_equal(supports[high + 1], supports[chosen]):
        high += 1
    middle = float(np.sqrt(thresholds[low] * thresholds[high]))
    return ThresholdPath(
        thresholds, mse, se, np.array([s.sum() for s in supports]), np.array(supports), middle,
        (float(thresholds[low]), float(thresholds[high])), rule, folds,
    )  # fmt: skip


def bagging(
    stats: BlockStats,
    threshold: float,
    n_models: int,
    rng: np.random.Generator,
    *,
    alpha: float = 0.0,
    max_iter: int = 20,
    keep: np.ndarray | None = None,
) -> np.ndarray:
    """Coefficients (n_models x p) of STLSQ on blocked-bootstrap resamples of the blocks."""
    out = np.zeros((n_models, stats.n_features))
    for m in range(n_models):
        draws = rng.integers(0, stats.n_blocks, size=stats.n_blocks)
        weights = np.bincount(draws, minlength=stats.n_blocks).astype(float)
        out[m] = stlsq(combine(stats, weights), threshold, alpha, max_iter, keep)
    return out
