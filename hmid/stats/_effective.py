"""Inference on the effective sample size of a correlated residual: nested-model tests and
likelihood intervals.

A residual correlated for tau_int samples (:func:`hmid.stats.residual_tau_int`) carries about
``n_eff = n / tau_int`` independent samples; a test or likelihood that counted all n would be
tau_int times too confident. Here: the extra-sum-of-squares F-test and BIC of a bigger model
against a smaller one on n_eff (:class:`NestedTest`), Holm's correction over a round of candidate
tests (:func:`holm`), and the profile-likelihood interval of a grid parameter on n_eff
(:func:`profile_interval`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class NestedTest:
    """Extra-sum-of-squares F-test of a model with ``q`` more parameters, on n_eff samples."""

    f: float
    p_value: float
    delta_bic: float  # BIC(bigger) - BIC(smaller) with n_eff; negative favours the bigger model
    q: int

    @classmethod
    def of(cls, sse0: float, sse1: float, q: int, p1: int, n_eff: float) -> NestedTest:
        from scipy import stats

        if q == 0:  # the candidate adds nothing the model lacks (e.g. a level it already has)
            return cls(0.0, 1.0, 0.0, 0)
        df = max(n_eff - p1, 1.0)
        f = max(sse0 - sse1, 0.0) / q / (sse1 / df)
        delta_bic = n_eff * np.log(sse1 / sse0) + q * np.log(n_eff)
        return cls(float(f), float(stats.f.sf(f, q, df)), float(delta_bic), q)


def holm(p: Sequence[float] | np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p-values (family-wise error over one round's candidates)."""
    values = np.asarray(p, dtype=float)
    if values.size == 0:
        return values
    order = np.argsort(values)
    scaled = values[order] * (values.size - np.arange(values.size))
    adjusted = np.minimum(np.maximum.accumulate(scaled), 1.0)
    out = np.empty_like(values)
    out[order] = adjusted
    return out


def profile_interval(
    grid: np.ndarray, sse: np.ndarray, n_eff: float, confidence: float
) -> tuple[float, float]:
    """Grid values whose profile likelihood ratio n_eff ln(SSE/SSE_min) is within the chi²(1)
    quantile: a likelihood interval at the grid's resolution."""
    from scipy import stats

    inside = n_eff * np.log(sse / sse.min()) <= stats.chi2.ppf(confidence, 1)
    return float(grid[inside].min()), float(grid[inside].max())
