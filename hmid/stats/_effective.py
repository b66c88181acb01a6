"""Inference on the effective sample size of a correlated residual: nested-model tests and
likelihood intervals.

A residual correlated for tau_int samples (:func:`hmid.stats.residual_tau_int`) carries about
``n_eff = n / tau_int`` independent samples; a test or likelihood that counted all n would be
tau_int times too confident. Here: the extra-sum-of-squares F-test and BIC of a bigger model
against a smaller one on n_eff (:class:`NestedTest`), Holm's correction over a round of candidate
tests (:func:`holm`), and the profile-likelihood interval of a grid parameter on n_eff
(:func:`likelihood_interval`).
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


def likelihood_interval(
    grid, sse, n_eff: float, confidence: float, best: tuple[float, float], log: bool = False
) -> tuple[float, float]:
    """The profile-likelihood interval of a profiled parameter, to the precision of its
    estimate: ``best`` = (value, SSE) of the refined fit (between grid points) joins the grid's
    profile (SSE; inf where not evaluated), and each end is where the likelihood ratio
    n_eff ln(SSE/SSE_min) crosses the chi²(1) quantile, interpolated in its square root (about
    linear in the parameter near the optimum; in the logarithm of the parameter on a log grid)
    between the last value inside and the first outside. An end with no value outside it is the
    grid's edge. The interval always contains the estimate."""
    value, least = best
    x = np.append(np.asarray(grid, dtype=float), value)
    s = np.append(np.asarray(sse, dtype=float), least)
    order = np.argsort(x, kind="stable")
    x, s = x[order], s[order]
    known = np.isfinite(s)
    x, s = x[known], s[known]
    root = np.sqrt(np.maximum(n_eff * np.log(s / s.min()), 0.0))
    from scipy.stats import chi2

    limit = np.sqrt(chi2.ppf(confidence, 1))
    inside = np.flatnonzero(root <= limit)
    logarithmic = log and bool(np.all(x > 0))
    u = np.log(x) if logarithmic else x
    ends = []
    for i, outer in ((inside.min(), -1), (inside.max(), 1)):
        j = i + outer
        if not 0 <= j < len(x):
            ends.append(float(x[i]))  # the grid's edge
            continue
        end = u[i] + (u[j] - u[i]) * (limit - root[i]) / (root[j] - root[i])
        ends.append(float(np.exp(end)) if logarithmic else float(end))
    return min(ends[0], value), max(ends[1], value)


def block_resamples(draws: int, blocks: int, seed: int) -> np.ndarray:
    """A block bootstrap's resamples: counts (draws, blocks) of each block in each resample,
    blocks drawn with replacement, from ``seed`` (the same resamples wherever the same seed and
    blocks are given, so paired statistics share them)."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(blocks, np.full(blocks, 1.0 / blocks), size=draws)
