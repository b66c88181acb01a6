"""A polynomial's design by blocks of rows (private to :mod:`hmid.models.polynomial`).

Only the columns a family gives smoothed after their product (which need whole segments) are
held whole; products of smoothed channels and the plain terms are computed for each block of
rows, so a long log's design is never held whole.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial

import numpy as np

from hmid.models._lstsq import RowBlocks
from hmid.models.terms import Term


def row_design(
    terms: Sequence[Term],
    X: Mapping[str, np.ndarray],
    scales: Mapping[str, float],
    given: Mapping[str, np.ndarray],
) -> RowBlocks:
    """The scaled design of ``terms`` on ``X``'s rows; ``given`` holds a term's column by name
    and, through an optional ``product(name)``, says which of them are products row by row."""
    local = getattr(given, "product", lambda name: None)
    arrays = {v: np.asarray(X[v], dtype=float) for v in X}
    columns = []
    for term in terms:
        factor = term.scale_factor(scales)
        powers = local(term.name) if term.name in given else None
        if term.name in given and powers is None:
            columns.append((np.asarray(given[term.name], float) / factor).__getitem__)
        elif term.name in given:
            columns.append(partial(_product, arrays, powers, factor))
        else:
            columns.append(partial(_evaluated, term, arrays, scales))
    n = len(next(iter(X.values()))) if X else 0
    return RowBlocks(n, columns)


def _product(arrays, powers: Mapping[str, int], factor: float, rows: slice) -> np.ndarray:
    # the balance's product of smoothed channels (ChannelTerm), on these rows alone
    values = np.ones(len(arrays[next(iter(powers))][rows]))
    for channel, power in powers.items():
        values = values * arrays[channel][rows] ** power
    return values / factor


def _evaluated(term: Term, arrays, scales, rows: slice) -> np.ndarray:
    n = len(next(iter(arrays.values()))[rows]) if arrays else rows.stop - rows.start
    return term.evaluate({v: arrays[v][rows] for v in term.variables}, scales, n)
