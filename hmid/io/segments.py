"""Splitting a log where its logger paused, so that filters never run across a gap."""

from __future__ import annotations

import itertools

import numpy as np

from hmid.io.log import Log


def split_at_gaps(log: Log, max_gap_s: float) -> list[Log]:
    """The contiguous pieces of ``log``: a new piece starts after every step > ``max_gap_s``.

    Nothing is dropped: the pieces hold every sample, in order.
    """
    if not max_gap_s > 0:
        raise ValueError(f"max_gap_s={max_gap_s!r} must be > 0 s")
    t = log.t
    starts = np.concatenate([[0], np.flatnonzero(np.diff(t) > max_gap_s) + 1, [len(t)]])
    return [log.between(t[a], t[b - 1]) for a, b in itertools.pairwise(starts)]
