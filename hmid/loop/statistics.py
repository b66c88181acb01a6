"""Tests of nested models on correlated residuals: the extra-sum-of-squares F-test and BIC on the
effective sample size, and Holm's correction over a round of candidates.

Autocorrelation, the integrated autocorrelation time and parameter intervals are the balance's
(:mod:`hmid.balance.statistics`): every test here counts ``n_eff = n / tau_int`` samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class NestedTest:
    """Extra-sum-of-squares F-test of a model with ``q`` more parameters, on n_eff samples."""

    f: float
    p_value: float
    delta_bic: float  # BIC(bigger) - BIC(smaller) with n_eff; negative favours the bigger model
    q: int

    @classmethod
    def of(cls, sse0: float, sse1: float, q: int, p1: int, n_eff: float) -> NestedTest:
        if q == 0:  # the candidate adds nothing the model lacks (e.g. a level it already has)
            return cls(0.0, 1.0, 0.0, 0)
        df = max(n_eff - p1, 1.0)
        f = max(sse0 - sse1, 0.0) / q / (sse1 / df)
        delta_bic = n_eff * np.log(sse1 / sse0) + q * np.log(n_eff)
        return cls(float(f), float(stats.f.sf(f, q, df)), float(delta_bic), q)


def holm(p: list[float]) -> np.ndarray:
    """Holm's step-down adjusted p-values (family-wise error over one round's candidates)."""
    p = np.asarray(p, dtype=float)
    if p.size == 0:
        return p
    order = np.argsort(p)
    scaled = p[order] * (p.size - np.arange(p.size))
    adjusted = np.minimum(np.maximum.accumulate(scaled), 1.0)
    out = np.empty_like(p)
    out[order] = adjusted
    return out
