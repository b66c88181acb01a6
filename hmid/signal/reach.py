"""How far a linear filter reaches: the samples either side of i that its output at i reads."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: Samples of the time base that the reach is measured on (far more than any filter's window).
STRETCH = 1 << 17


def impulse_reach(t: np.ndarray, apply: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> int:
    """Samples either side of the middle that ``apply(t, y)`` mixes into its output there (the
    support of its impulse response), for a time base like ``t``."""
    # a stretch from the middle: a long log's reach, at a fraction of the cost and memory
    if len(t) > STRETCH:
        start = (len(t) - STRETCH) // 2
        t = t[start : start + STRETCH]
    impulse = np.zeros(len(t))
    mid = len(t) // 2
    impulse[mid] = 1.0
    response = np.abs(apply(t, impulse))
    support = np.flatnonzero(response > 1e-9 * response.max())
    return int(max(mid - support[0], support[-1] - mid))
