"""Selection kept apart from the reported error: blocked cross-validation on the training rows.

Training rows are cut into contiguous time blocks (``block_s`` long, within each segment), dealt
to ``folds`` folds in turn. Each fold is predicted by the model fitted on the other folds, with
every profiled parameter held at its training value; so every training row gets an out-of-fold
residual, and the comparison's held-out rows (where the loop reports its before and after) are
never seen by a decision. The block bootstrap (blocks drawn with replacement, from the
experiment's seed) gives the uncertainty of the change in out-of-fold RMSE, on the same blocks.

Where the comparison holds out whole logs (operating points), selection asks the same question:
the same blocks are also dealt by log, every training log left out whole in turn
(:meth:`Folds.by_log`), and a candidate must lower the out-of-fold RMSE both ways (the stricter
wins): an addition that helps only within the logs it was fitted on (a difference between
operating points) fails it. A trend that also predicts each left-out training log passes, though it
may still mispredict a held-out one (a line through 1, 3 and 7 bar at 5 bar, where friction is
convex in pressure): the loop then says so after the fact (:func:`hmid.loop.result.rises`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.balance import Signals, Structure, fit_structure


@dataclass(frozen=True)
class Folds:
    """Training rows in time blocks, each block in one fold."""

    block: np.ndarray  # block index of every row (-1: not a training row)
    fold: np.ndarray  # fold of each block

    @classmethod
    def of(cls, signals: Signals, folds: int, block_s: float) -> Folds:
        block, _ = _blocks(signals, block_s)
        return cls(block, np.arange(int(block.max()) + 1) % folds)

    @classmethod
    def by_log(cls, signals: Signals, block_s: float) -> Folds | None:
        """The same time blocks (so they share a bootstrap), each log's in one fold: every
        training log left out whole in turn, as a split that holds out whole logs asks (None
        if the training rows are of fewer than two logs)."""
        block, logs = _blocks(signals, block_s)
        if len(set(logs)) < 2:
            return None
        return cls(block, pd.factorize(np.asarray(logs))[0])

    @property
    def blocks(self) -> int:
        return len(self.fold)

    def rows(self, k: int) -> np.ndarray:
        """Rows of fold ``k`` (mask)."""
        return (self.block >= 0) & (self.fold[np.maximum(self.block, 0)] == k)

    def block_sums(self, values: np.ndarray) -> np.ndarray:
        inside = self.block >= 0
        return np.bincount(self.block[inside], weights=values[inside], minlength=self.blocks)


def _blocks(signals: Signals, block_s: float) -> tuple[np.ndarray, list]:
    """Block index of every row (-1: not a training row) and the log of each block."""
    block = np.full(len(signals), -1)
    train, t, log, count, logs = signals.train, signals["t"], signals.frame["log"], 0, []
    for rows in signals.segments():
        rows = rows[train[rows]]
        if not len(rows):
            continue
        index = np.floor((t[rows] - t[rows[0]]) / block_s).astype(int)
        _, index = np.unique(index, return_inverse=True)
        block[rows] = count + index
        count += int(index.max()) + 1
        logs += [log.iat[rows[0]]] * (int(index.max()) + 1)
    return block, logs


def out_of_fold(structure: Structure, signals: Signals, folds: Folds) -> np.ndarray:
    """The residual of each training row predicted by the fit on the other folds (NaN
    elsewhere); profiled parameters stay at ``structure``'s values."""
    residual = np.full(len(signals), np.nan)
    for k in range(int(folds.fold.max()) + 1 if folds.blocks else 0):
        held = folds.rows(k)
        fitted = fit_structure(structure, signals, rows=signals.train & ~held)
        residual[held] = fitted.residual[held]
    return residual


@dataclass(frozen=True)
class Change:
    """Relative change of the out-of-fold RMSE (negative: better), with its bootstrap bound."""

    change: float
    upper: float  # one-sided upper bound at the confidence (the change is at most this)
    lower: float

    def better(self, margin: float) -> bool:
        """Confidently better: even the upper bound lowers the RMSE by more than ``margin``."""
        return self.upper < -margin


def change(
    before: np.ndarray, after: np.ndarray, folds: Folds, counts: np.ndarray, confidence: float
) -> Change:
    """The relative change sqrt(SSE_after / SSE_before) - 1 of two out-of-fold residuals."""
    s0 = folds.block_sums(np.nan_to_num(before) ** 2)
    s1 = folds.block_sums(np.nan_to_num(after) ** 2)
    point = float(np.sqrt(s1.sum() / s0.sum()) - 1.0)
    resampled = np.sqrt((counts @ s1) / (counts @ s0)) - 1.0
    return Change(point, float(np.quantile(resampled, confidence)),
                  float(np.quantile(resampled, 1.0 - confidence)))  # fmt: skip
