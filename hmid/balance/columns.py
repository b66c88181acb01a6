"""Design columns whose coefficients *are* physical parameters, and their least-squares fit.

A column carries its parameter's name and unit, whether physics makes that parameter positive
(a mass, a stiffness, a friction level, with the sign of the term built into the column), and the
channels it reads (so that a parameter with the wrong sign can be traced to a channel).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Column:
    """One regressor: ``values`` (n,) times the parameter ``name`` [``unit``]."""

    name: str
    values: np.ndarray = field(repr=False)
    unit: str
    positive: bool = False
    reads: tuple[str, ...] = ()


@dataclass(frozen=True)
class Columns:
    """``values`` (n, p); column j's coefficient is parameter ``names[j]`` in ``units[j]``."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    values: np.ndarray = field(repr=False)
    positive: tuple[bool, ...] = ()
    reads: tuple[tuple[str, ...], ...] = ()

    def __post_init__(self) -> None:
        width = len(self.names)
        if not self.positive:
            object.__setattr__(self, "positive", (False,) * width)
        if not self.reads:
            object.__setattr__(self, "reads", ((),) * width)
        if not (len(self.units) == len(self.positive) == len(self.reads) == width):
            raise ValueError("Columns: names, units, positive and reads must have equal lengths")
        if self.values.ndim != 2 or self.values.shape[1] != width:
            raise ValueError(f"Columns: values of shape {self.values.shape} for {width} names")

    @classmethod
    def empty(cls, n: int) -> Columns:
        return cls((), (), np.empty((n, 0)))

    @classmethod
    def stack(cls, n: int, columns: list[Column] | tuple[Column, ...]) -> Columns:
        if not columns:
            return cls.empty(n)
        values = np.column_stack([np.asarray(c.values, dtype=float) for c in columns])
        return cls(
            tuple(c.name for c in columns),
            tuple(c.unit for c in columns),
            values,
            tuple(c.positive for c in columns),
            tuple(c.reads for c in columns),
        )

    def __add__(self, other: Columns) -> Columns:
        return Columns(
            self.names + other.names,
            self.units + other.units,
            np.hstack([self.values, other.values]),
            self.positive + other.positive,
            self.reads + other.reads,
        )

    def select(self, keep: list[int]) -> Columns:
        return Columns(
            tuple(self.names[i] for i in keep),
            tuple(self.units[i] for i in keep),
            self.values[:, keep],
            tuple(self.positive[i] for i in keep),
            tuple(self.reads[i] for i in keep),
        )

    @property
    def width(self) -> int:
        return len(self.names)

    @classmethod
    def combine(cls, n: int, parts, rows: np.ndarray, memo: dict | None = None) -> Columns:
        """The columns of :func:`plan` in one array."""
        return plan(n, parts, rows, memo).assemble()


@dataclass(frozen=True)
class Plan:
    """Which columns of which parts a design holds, before any array is assembled: profiling
    fits thousands of designs from the same few parts, and their Gram blocks are cached."""

    n: int
    parts: tuple[tuple[object, Columns, tuple[int, ...]], ...]  # (key, columns, kept indices)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.names[j] for _, c, keep in self.parts for j in keep)

    @property
    def width(self) -> int:
        return sum(len(keep) for _, _, keep in self.parts)

    def assemble(self, rows: np.ndarray | None = None) -> Columns:
        """The design in one array: on every row, or on ``rows`` only (a mask or indices; the
        rows are taken before the columns, so a long log's design is never held whole)."""
        if not self.parts:
            return Columns.empty(self.n if rows is None else len(np.arange(self.n)[rows]))
        values = [(c.values if rows is None else c.values[rows])[:, list(keep)]
                  for _, c, keep in self.parts]  # fmt: skip
        picked = [(c, j) for _, c, keep in self.parts for j in keep]
        return Columns(
            tuple(c.names[j] for c, j in picked),
            tuple(c.units[j] for c, j in picked),
            np.hstack(values),
            tuple(c.positive[j] for c, j in picked),
            tuple(c.reads[j] for c, j in picked),
        )


def plan(n: int, parts, rows: np.ndarray, memo: dict | None = None) -> Plan:
    """The columns of ``parts`` (triples of a key, Columns, and whether they refine the earlier
    ones), each entering once: a parameter already present by name, or a column equal to one
    present (a correction two terms share), is not added again; a refining part drops the
    earlier columns its span holds (see :func:`_spanned`). Both decisions are remembered in
    ``memo`` by the parts' keys."""
    memo = {} if memo is None else memo
    kept: list[list] = []  # per part: [key, Columns, indices kept]
    for key, columns, refines in parts:
        if refines and columns.width:
            for entry in kept:
                spanned = memo.get(("spanned", entry[0], key))
                if spanned is None:
                    basis = memo.get(("span", key))
                    if basis is None:
                        basis = memo[("span", key)] = _orthonormal(columns.values[rows])
                    spanned = memo[("spanned", entry[0], key)] = {
                        j for j in range(entry[1].width)
                        if _spanned(entry[1].values[rows, j], basis)
                    }  # fmt: skip
                entry[2] = [j for j in entry[2] if j not in spanned]
        names = {entry[1].names[j] for entry in kept for j in entry[2]}
        keep = []
        for i, name in enumerate(columns.names):
            if name in names:
                continue
            equal = memo.get(("equal", key, i, tuple((e[0], tuple(e[2])) for e in kept)))
            if equal is None:
                equal = any(_equal(columns.values[:, i], entry[1].values[:, j])
                            for entry in kept for j in entry[2])  # fmt: skip
                memo[("equal", key, i, tuple((e[0], tuple(e[2])) for e in kept))] = equal
            if not equal:
                keep.append(i)
        kept.append([key, columns, keep])
    return Plan(n, tuple((key, c, tuple(keep)) for key, c, keep in kept if keep))


def _equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a[0] == b[0] and a[-1] == b[-1] and np.array_equal(a, b)


def _orthonormal(basis: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the span of ``basis``'s columns (singular values above lstsq's
    default cut-off): found once per refining part, then each column is tested by projection."""
    u, s, _ = np.linalg.svd(basis, full_matrices=False)
    if not len(s) or s[0] == 0:
        return u[:, :0]
    return u[:, s > np.finfo(float).eps * max(basis.shape) * s[0]]


def _spanned(column: np.ndarray, basis: np.ndarray, tol: float = 1e-8) -> bool:
    """Whether the span of ``basis`` (orthonormal columns) holds ``column`` (relative residual
    below ``tol``): a term that refines another (viscous friction by direction of motion
    refines one viscous coefficient) takes those columns' place, so its coefficients are the
    whole physical parameters rather than corrections of a rank-deficient pair."""
    norm = np.linalg.norm(column)
    if norm == 0:
        return False
    return bool(np.linalg.norm(column - basis @ (basis.T @ column)) <= tol * norm)


@dataclass(frozen=True)
class LeastSquares:
    """Least squares of ``y`` on columns over the masked rows.

    Solved from the normal equations of the scaled columns (fits of a few columns on tens of
    thousands of rows are repeated hundreds of times while profiling; the Gram matrix is one BLAS
    call) with an SVD pseudo-inverse, so a rank-deficient design still gives the minimum-norm
    solution.
    """

    coef: np.ndarray
    sse: float
    n: int

    @classmethod
    def fit(cls, columns: Columns, y: np.ndarray, rows: np.ndarray) -> LeastSquares:
        X, target = columns.values[rows], y[rows]
        if X.shape[1] == 0:
            return cls(np.empty(0), float(target @ target), int(rows.sum()))
        scale = np.sqrt(np.einsum("ij,ij->j", X, X))
        scale[scale == 0] = 1.0
        Xs = X / scale
        gram, moment = Xs.T @ Xs, Xs.T @ target
        coef_s = np.linalg.pinv(gram, rcond=1e-12, hermitian=True) @ moment
        sse = float(target @ target - 2 * coef_s @ moment + coef_s @ gram @ coef_s)
        if sse < 1e-9 * float(target @ target):  # cancellation: recompute directly
            sse = float(np.sum((target - Xs @ coef_s) ** 2))
        return cls(coef_s / scale, max(sse, 0.0), int(rows.sum()))

    @classmethod
    def from_plan(
        cls, plan: Plan, y: np.ndarray, rows: np.ndarray, memo: dict, y_key=None
    ) -> LeastSquares:
        """:meth:`fit` of the plan's design from Gram blocks of its parts, each computed once
        per pair of parts and set of rows (``memo``; ``y_key`` names ``y`` there, default its
        digest): no design is assembled."""
        n_rows, rows_key = int(rows.sum()), _digest(rows)
        y_key = _digest(y) if y_key is None else y_key
        target = memo.get(("target", y_key, rows_key))
        if target is None:
            target = memo[("target", y_key, rows_key)] = (y[rows], float(y[rows] @ y[rows]))
        y_rows, yy = target
        if plan.width == 0:
            return cls(np.empty(0), yy, n_rows)

        def on_rows(key, columns):
            found = memo.get(("on rows", key, rows_key))
            if found is None:
                found = memo[("on rows", key, rows_key)] = columns.values[rows]
            return found

        offsets = np.cumsum([0, *(len(keep) for _, _, keep in plan.parts)])
        gram = np.empty((plan.width, plan.width))
        for i, (key_i, c_i, keep_i) in enumerate(plan.parts):
            for j in range(i, len(plan.parts)):
                key_j, c_j, keep_j = plan.parts[j]
                block = memo.get(("gram", key_i, key_j, rows_key))
                if block is None:
                    block = on_rows(key_i, c_i).T @ on_rows(key_j, c_j)
                    memo[("gram", key_i, key_j, rows_key)] = block
                if len(keep_i) != block.shape[0] or len(keep_j) != block.shape[1]:
                    block = block[np.ix_(keep_i, keep_j)]
                gram[offsets[i] : offsets[i + 1], offsets[j] : offsets[j + 1]] = block
                gram[offsets[j] : offsets[j + 1], offsets[i] : offsets[i + 1]] = block.T
        moments = []
        for key, c, keep in plan.parts:
            m = memo.get(("moment", key, y_key, rows_key))
            if m is None:
                m = memo[("moment", key, y_key, rows_key)] = on_rows(key, c).T @ y_rows
            moments.append(m[list(keep)])
        moment = np.concatenate(moments)
        scale = np.sqrt(np.diag(gram)).copy()
        scale[scale == 0] = 1.0
        gram_s, moment_s = gram / np.outer(scale, scale), moment / scale
        coef_s = np.linalg.pinv(gram_s, rcond=1e-12, hermitian=True) @ moment_s
        sse = float(yy - 2 * coef_s @ moment_s + coef_s @ gram_s @ coef_s)
        if sse < 1e-9 * yy:  # cancellation: from the design itself
            return cls.fit(plan.assemble(), y, rows)
        return cls(coef_s / scale, max(sse, 0.0), n_rows)

    def predict(self, columns: Columns) -> np.ndarray:
        return columns.values @ self.coef


def _digest(values: np.ndarray) -> bytes:
    """A key for a row mask or a target in the memo (arrays are rebuilt on every access)."""
    data = np.packbits(values) if values.dtype == bool else np.ascontiguousarray(values)
    return hashlib.blake2b(data.tobytes(), digest_size=16).digest()
