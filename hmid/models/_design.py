"""A polynomial's design by blocks of rows (private to :mod:`hmid.models.polynomial`).

A term whose column the caller can compute on any block of rows (a product of smoothed channels,
or one of unsmoothed channels smoothed after it, see ``given.block``) and the plain terms are
computed for each block of rows, so a long log's design is never held whole; only columns given
as arrays are held.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import partial

import numpy as np

from hmid.balance.monomial import Monomial
from hmid.models._lstsq import RowBlocks


def row_design(
    terms: Sequence[Monomial],
    X: Mapping[str, np.ndarray],
    scales: Mapping[str, float],
    given: Mapping[str, np.ndarray],
    n: int | None = None,
) -> RowBlocks:
    """The scaled design of ``terms`` on ``X``'s rows (``n`` of them where ``X`` holds no
    column); ``given`` holds a term's column by name and, through an optional
    ``block(name)``, a function of a slice of rows giving it there."""
    block = getattr(given, "block", None)
    arrays = {v: np.asarray(X[v], dtype=float) for v in X}
    columns: list[Callable[[slice], np.ndarray]] = []
    for term in terms:
        factor = term.scale_factor(scales)
        if term.name in given and block is not None:
            columns.append(partial(_scaled, block(term.name), factor))
        elif term.name in given:
            columns.append((np.asarray(given[term.name], float) / factor).__getitem__)
        else:
            columns.append(partial(_evaluated, term, arrays, scales))
    if n is None:
        n = len(next(iter(X.values()))) if X else 0
    return RowBlocks(n, columns)


def _scaled(column: Callable[[slice], np.ndarray], factor: float, rows: slice) -> np.ndarray:
    return column(rows) / factor


def _evaluated(term: Monomial, arrays, scales, rows: slice) -> np.ndarray:
    n = len(next(iter(arrays.values()))[rows]) if arrays else rows.stop - rows.start
    return term.evaluate({v: arrays[v][rows] for v in term.variables}, scales, n)
