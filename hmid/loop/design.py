"""Named design columns whose coefficients *are* physical parameters (signs built in)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Columns:
    """``values`` (n, p); column j's coefficient is parameter ``names[j]`` in ``units[j]``."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    values: np.ndarray

    @classmethod
    def empty(cls, n: int) -> Columns:
        return cls((), (), np.empty((n, 0)))

    @classmethod
    def of(cls, n: int, **columns: tuple[np.ndarray, str]) -> Columns:
        """``Columns.of(n, b=(values, "N·s/m"), ...)``."""
        if not columns:
            return cls.empty(n)
        names = tuple(columns)
        values = np.column_stack([np.asarray(columns[k][0], dtype=float) for k in names])
        return cls(names, tuple(columns[k][1] for k in names), values)

    def __add__(self, other: Columns) -> Columns:
        return Columns(
            self.names + other.names,
            self.units + other.units,
            np.hstack([self.values, other.values]),
        )

    @property
    def width(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class LeastSquares:
    """Least squares of ``y`` on columns over the masked rows.

    Solved from the normal equations of the scaled columns (the loop fits hundreds of designs
    of a few columns on tens of thousands of rows; the Gram matrix is one BLAS call) with an
    SVD pseudo-inverse, so a rank-deficient design still gives the minimum-norm solution.
    """

    coef: np.ndarray
    sse: float
    n: int

    @classmethod
    def fit(cls, columns: Columns, y: np.ndarray, rows: np.ndarray) -> LeastSquares:
        X, target = columns.values[rows], y[rows]
        scale = np.sqrt(np.einsum("ij,ij->j", X, X))
        scale[scale == 0] = 1.0
        Xs = X / scale
        gram, moment = Xs.T @ Xs, Xs.T @ target
        coef_s = np.linalg.pinv(gram, rcond=1e-12, hermitian=True) @ moment
        sse = float(target @ target - 2 * coef_s @ moment + coef_s @ gram @ coef_s)
        if sse < 1e-9 * float(target @ target):  # cancellation: recompute directly
            sse = float(np.sum((target - Xs @ coef_s) ** 2))
        return cls(coef_s / scale, max(sse, 0.0), int(rows.sum()))

    def predict(self, columns: Columns) -> np.ndarray:
        return columns.values @ self.coef
