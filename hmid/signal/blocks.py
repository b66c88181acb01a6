"""A long signal smoothed block by block: each block of samples with the smoother's margin
around it (:meth:`~hmid.signal.Smoother.local`), so that what is smoothed (a product, a sign, a
friction law of the velocity) is never held whole beside its smoothed version."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: Samples per block: large enough that the margins cost little, small beside a long log.
BLOCK = 1 << 16

Local = tuple[int, Callable[[np.ndarray], np.ndarray]]


def local_smoother(smoother, t: np.ndarray) -> Local:
    """``smoother.local(t)``, or the whole of ``t`` as its margin for one that reads it all."""
    return smoother.local(t) or (len(t), smoother.on(t))


def smoothed_span(local: Local, n: int, values_of, lo: int, hi: int) -> np.ndarray:
    """Samples ``lo:hi`` of the smoothed signal of ``n`` samples whose values on a slice ``s``
    are ``values_of(s)``, computed on ``lo:hi`` and the margin either side."""
    margin, smooth = local
    a, b = max(0, lo - margin), min(n, hi + margin)
    return smooth(values_of(slice(a, b)))[lo - a : hi - a]


def smoothed_by_blocks(
    local: Local, n: int, values_of, block: int = BLOCK, out: np.ndarray | None = None
) -> np.ndarray:
    """The whole smoothed signal (see :func:`smoothed_span`), one block at a time; written into
    ``out`` (``n`` samples) where given."""
    out = np.empty(n) if out is None else out
    for lo in range(0, n, block):
        out[lo : lo + block] = smoothed_span(local, n, values_of, lo, min(lo + block, n))
    return out
