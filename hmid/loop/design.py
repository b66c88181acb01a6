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
    """Least squares of ``y`` on columns over the masked rows (columns scaled for conditioning)."""

    coef: np.ndarray
    sse: float
    n: int

    @classmethod
    def fit(cls, columns: Columns, y: np.ndarray, rows: np.ndarray) -> LeastSquares:
        X = columns.values[rows]
        scale = np.max(np.abs(X), axis=0)
        scale[scale == 0] = 1.0
        coef, *_ = np.linalg.lstsq(X / scale, y[rows], rcond=None)
        coef = coef / scale
        residual = y[rows] - X @ coef
        return cls(coef, float(residual @ residual), int(rows.sum()))

    def predict(self, columns: Columns) -> np.ndarray:
        return columns.values @ self.coef
