"""Rival explanations said out loud, with the test that would tell them apart."""

from __future__ import annotations

import numpy as np

from hmid.balance import Signals
from hmid.loop.candidates import Candidate


def rivals(best: Candidate, others: list[Candidate]) -> list[Candidate]:
    """Those of ``others`` that are other physics than ``best``, not a special case of it or a
    refinement of it."""
    return [
        c for c in others
        if c.name != best.name and not c.special_case_of(best) and not best.special_case_of(c)
    ]  # fmt: skip


def _correlation(signals: Signals, a: str, b: str) -> float | None:
    if a not in signals or b not in signals:
        return None
    rows = signals.train
    x, y = signals[a][rows], signals[b][rows]
    if np.std(x) == 0 or np.std(y) == 0:
        return None
    return float(np.corrcoef(x, y)[0, 1])


def separating(a: Candidate, b: Candidate, signals: Signals) -> str:
    """The experiment that separates ``a`` from ``b``: vary what one follows with the other's
    held, with how strongly the two moved together in these logs."""
    fa, fb = a.follows, b.follows
    if fa == fb:
        return (
            f"both follow {fa}: logs where {fa} changes faster and over a wider range separate "
            "them by the shape of their response, not its timing alone"
        )
    text = (
        f"{a.name} follows {fa}, {b.name} follows {fb}: vary {fa} with {fb} held fixed, "
        f"and the reverse"
    )
    if "t" in (fa, fb):
        return text + " (repeat a test later, or in the reverse order: a drift follows the clock)"
    r = _correlation(signals, fa, fb)
    if r is not None:
        text += f" (on these training rows they move together: r = {r:+.2f})"
    return text
