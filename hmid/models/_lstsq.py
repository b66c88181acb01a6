"""Least squares on a tall design without a copy of it.

The R factor of ``[X y]`` is built from blocks of rows, each QR-factored under the R so far (the
TSQR of Demmel et al.), so the memory beyond the design is one block, where statsmodels' pinv or a
full QR hold another n x p matrix. From R come the coefficients (by the pseudo-inverse, as
statsmodels' OLS), the rank and condition number (R has the singular values of X), and
``(X'X)^-1``, all as stable as a QR of the whole design.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

#: Rows per QR block: large enough for BLAS, small beside a long log.
QR_BLOCK = 32_768


@dataclass(frozen=True)
class TallFit:
    """``params``, the residual, and the R factor of the design (p x p)."""

    params: np.ndarray
    resid: np.ndarray
    r: np.ndarray
    n: int

    @property
    def singular_values(self) -> np.ndarray:
        return np.linalg.svd(self.r, compute_uv=False)

    @property
    def rank(self) -> int:
        """numpy's ``matrix_rank`` rule on the design's singular values."""
        s = self.singular_values
        return int(
            np.sum(s > s.max(initial=0.0) * max(self.r.shape[1], self.n) * np.finfo(float).eps)
        )

    def condition_number(self, column_factor: np.ndarray | None = None) -> float:
        """Condition number of the design, or of the design with column k multiplied by
        ``column_factor[k]`` (its R is R times the same diagonal)."""
        r = self.r if column_factor is None else self.r * column_factor
        s = np.linalg.svd(r, compute_uv=False)
        return float(s.max() / s.min()) if s.min() > 0 else float("inf")

    def bread(self) -> np.ndarray:
        """``(X'X)^-1`` (a pseudo-inverse where X is rank-deficient)."""
        inverse = np.linalg.pinv(self.r, rcond=1e-15)
        return inverse @ inverse.T


class RowBlocks:
    """A tall design held by columns, each computed for any block of rows (``columns[k](rows)``,
    ``rows`` a slice): a column that is cheap to compute from others is never held whole.
    Sliced by rows it is an array; ``@`` and ``np.asarray`` work block by block."""

    def __init__(self, n: int, columns: Sequence[Callable[[slice], np.ndarray]]) -> None:
        self.columns = tuple(columns)
        self.shape = (n, len(self.columns))
        self._last: tuple[tuple[int, int], np.ndarray] | None = None

    def __getitem__(self, rows: slice) -> np.ndarray:
        start, stop, _ = rows.indices(self.shape[0])
        if self._last is not None and self._last[0] == (start, stop):
            return self._last[1]  # a short design is one block: built once for every pass
        out = np.empty((max(stop - start, 0), self.shape[1]))
        for k, column in enumerate(self.columns):
            out[:, k] = column(slice(start, stop))
        if stop - start <= QR_BLOCK:
            out.flags.writeable = False
            self._last = ((start, stop), out)
        return out

    def __matmul__(self, params: np.ndarray) -> np.ndarray:
        out = np.empty(self.shape[0])
        for i in range(0, self.shape[0], QR_BLOCK):
            out[i : i + QR_BLOCK] = self[i : i + QR_BLOCK] @ params
        return out

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self[:]
        if dtype is not None and out.dtype != dtype:
            return out.astype(dtype)
        return out if out.flags.writeable else out.copy()  # the held block stays as it is


def r_factor(a: np.ndarray) -> np.ndarray:
    """The R of a QR of ``a`` (m x k), min(m, k) x k: LAPACK's ``dgeqrf`` itself (numpy's
    ``qr(mode="r")`` calls the same routine after copying ``a`` to Fortran order, a third of
    its cost on a thin block); ``a`` in Fortran order is factored in place."""
    from scipy.linalg import lapack

    factored = lapack.dgeqrf(a, overwrite_a=a.flags.f_contiguous)[0]
    return np.triu(factored[: min(a.shape)])  # below the diagonal: the reflectors, not R


def tall_lstsq(exog: np.ndarray | RowBlocks, y: np.ndarray, block: int = QR_BLOCK) -> TallFit:
    """Ordinary least squares of ``y`` on ``exog`` (n x p), by blocks of ``block`` rows."""
    n, p = exog.shape
    r = np.zeros((0, p + 1))
    for start in range(0, n, block):
        stop = min(start + block, n)
        rows = np.empty((r.shape[0] + stop - start, p + 1), order="F")  # [R; X y], factored
        rows[: r.shape[0]] = r
        rows[r.shape[0] :, :p] = exog[start:stop]
        rows[r.shape[0] :, p] = y[start:stop]
        r = r_factor(rows)
    r_x, qty = r[:p, :p], r[:p, p]
    if r_x.shape[0] < p:  # fewer rows than terms
        r_x = np.vstack([r_x, np.zeros((p - r_x.shape[0], p))])
        qty = np.concatenate([qty, np.zeros(p - qty.size)])
    params = np.linalg.pinv(r_x, rcond=1e-15) @ qty
    return TallFit(params, y - exog @ params, r_x, n)
