"""The exact posterior's spread made honest for a correlated residual: a sandwich adjustment.

An i.i.d. likelihood on a residual that stays correlated for tau_int samples (the pipeline's
smoothing, errors in x, unmodelled structure) gives a posterior about sqrt(tau_int) too narrow.
Following Müller (2013, *Econometrica* 81, "Risk of Bayesian inference in misspecified
models"), the draws of (A_eff, F0, k1, [k3], k2, ln tau) are mapped affinely about their median,
theta -> m + C (theta - m), so that their covariance becomes the sandwich covariance of the
estimate, never narrower than the posterior's in any direction: the prediction's Jacobian J
with the residual's autocovariance up to Sokal's window, ``(JᵀJ)⁻¹ Jᵀ S J (JᵀJ)⁻¹``
(:func:`hmid.stats.autocov_covariance`, as the polynomial family's intervals). The
posterior's shape and sigma are kept; a white residual widens it by a few per cent (the
autocovariance's sampling noise, only ever widening). Calibrated by
``benchmarks/bench_sls_calibration.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from hmid.errors import ConfigError
from hmid.models.sls._data import SLSData
from hmid.models.sls._sampler_result import SamplerResult
from hmid.models.sls.terms import SLSForce
from hmid.signal.maxwell import responses
from hmid.stats import autocov_covariance, fitted_correlation

_H = 1e-3  # step in ln tau of the Jacobian's central difference


@dataclass(frozen=True)
class Adjustment:
    """What the adjustment did: the residual's correlation time (samples, corrected for the
    fit's projection, :func:`hmid.stats.fitted_correlation`) and Sokal's window (None: it
    outlasts the lags examined), each adjusted coordinate's width ratio, the residual's own
    correlation time and the effective sample size n / tau_int."""

    tau_int: float
    window: int | None
    widening: dict[str, float]
    raw_tau_int: float = float("nan")
    n_eff: float = float("nan")


def _jacobian(data: SLSData, force: SLSForce, beta: np.ndarray, log_tau: float) -> np.ndarray:
    """d prediction / d (A_eff, F0, k1, [k3], k2, ln tau) on the used rows."""
    taus = np.exp([log_tau - _H, log_tau, log_tau + _H])
    g = responses(data.t, data.x, data.start, taus, batch=4)
    fixed = force.fixed_columns(data.P, data.x, data.x3)
    d_tau = -beta[-1] * (g[:, 2] - g[:, 0]) / (2 * _H)
    return np.column_stack([*fixed, -g[:, 1], d_tau])[np.asarray(data.use)]


def sandwich_adjust(
    result: SamplerResult, data: SLSData, force: SLSForce
) -> tuple[SamplerResult, Adjustment]:
    """``result``'s draws (coordinates: the ``force``'s one arm's linear parameters, then ln
    tau) with the sandwich covariance for the residual at their median; and what changed."""
    if force.n_relaxation != 1:
        raise ConfigError(f"sandwich_adjust: one Maxwell arm, not {force.n_relaxation}")
    n_linear = force.n_linear
    k = n_linear + 1
    draws = result.chain[:, :k]
    centre = np.median(draws, axis=0)
    jac = _jacobian(data, force, centre[:n_linear], float(centre[n_linear]))
    residual = np.asarray(data.F)[np.asarray(data.use)] - jac[:, :n_linear] @ centre[:n_linear]
    scale = np.sqrt(np.mean(jac**2, axis=0))
    scale[scale == 0] = 1.0
    design = jac / scale
    bread = np.linalg.pinv(design.T @ design)
    # the residual's autocovariance with what the fit took back: on 4,000 rows the raw one
    # reads the pipeline's smoothing (tau_int 20) as 15, and 90 % intervals covered 0.85
    corr = fitted_correlation(residual, design, bread)
    target = autocov_covariance(design, corr.gamma, bread, spectrum=corr.spectrum)
    target /= np.outer(scale, scale)
    spread = np.cov(draws, rowvar=False)
    sd = np.sqrt(np.diag(spread))
    # in units of the posterior sd (well conditioned); in the posterior's whitened coordinates
    # the sandwich's eigenvalues say how much wider each direction must be. Only widened: a
    # sandwich narrower than the likelihood's curvature is sampling noise in the autocovariance.
    l_post = np.linalg.cholesky(spread / np.outer(sd, sd))
    inverse = np.linalg.inv(l_post)
    ratio, vectors = np.linalg.eigh(inverse @ (target / np.outer(sd, sd)) @ inverse.T)
    stretch = vectors @ np.diag(np.sqrt(np.maximum(ratio, 1.0))) @ vectors.T
    mapping = l_post @ stretch @ inverse
    adjusted = centre + ((draws - centre) / sd) @ mapping.T * sd
    chain = result.chain.copy()
    chain[:, :k] = adjusted
    walkers = result.walkers.copy()
    walkers[:, 0, :] = chain
    names = [name.removeprefix("log_") for name in result.names[:k]]  # ln tau's width: tau's
    widening = dict(zip(names, adjusted.std(axis=0) / sd, strict=True))
    out = replace(result, chain=chain, walkers=walkers)
    widths = {n: float(w) for n, w in widening.items()}
    return out, Adjustment(corr.tau_int, corr.window, widths, corr.raw_tau_int, corr.n_eff)
