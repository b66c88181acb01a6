"""Coefficient intervals of a fitted SINDy model: post-selection OLS (the default) or bootstrap.

``"autocov"`` (default): STLSQ ends with an unbiasing refit, so the selected terms' coefficients
*are* the OLS ones on the selected columns alone; their intervals are the polynomial family's
(:mod:`hmid.stats`): the OLS sandwich with the residual's Toeplitz autocovariance up
to Sokal's window, t intervals on ``min(n - p, n / (2 M + 1))`` degrees of freedom. They are
**conditional on the selected support**: they say how well the data pin down the coefficients of
this model, not whether another support would have been chosen from another noise draw (the
ensemble's inclusion probabilities answer that). Terms left out have no interval.

``"bootstrap"`` (the old default): percentile intervals of the blocked-bootstrap ensemble at the
chosen threshold, zeros included. Where a resample picks another support, its coefficients for
the shared terms move to absorb the difference, and the interval spans those moves.

Measured by ``benchmarks/bench_calibration_sindy.py`` (100 replications; the rig's muscle force
A_eff P - k1 x - k3 x³ on 20 s of the simulated rig, ~3000 sliding rows): ``autocov``'s 95 %
intervals cover 0.937-0.977 under white, AR(1) phi 0.5-0.97 and moving-average-smoothed noise,
0.96-1.15 times the needed width (OLS's on the true terms), the true support chosen in 99-100 %
of the fits (:mod:`~hmid.models.sindy._select`; where a fit chooses another, no interval
conditional on the support can cover). The bootstrap's cover 0.93-0.98, at 14-18 times the
needed width (1.8 under white noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hmid.intervals import IntervalNote
from hmid.stats import autocov_covariance, residual_correlation

#: Interval methods, the default first.
INTERVALS = ("autocov", "bootstrap")
#: The longest residual correlation time (rows, as a fit measures it) at which the default
#: intervals were measured: AR(1) phi = 0.97 in benchmarks/bench_calibration_sindy.py, 66 samples
#: of the 1 kHz noise, read as 33-35 rows on the sliding rows' bursts joined end to end.
SINDY_CALIBRATED_TAU = 35.0


@dataclass(frozen=True)
class Intervals:
    """Standard errors ``(p,)`` and intervals ``(p, 2)`` of every library term (NaN where a
    method gives none), with the residual's correlation (``tau_int`` rows, Sokal's ``window``
    in lags, None if it outlasts the lags examined) and the t intervals' ``df`` (None: not t);
    ``cov``: the selected terms' covariance (support x support, in the design's units)."""

    std_err: np.ndarray
    ci: np.ndarray
    tau_int: float
    window: int | None
    df: float | None
    cov: np.ndarray


def support_intervals(
    Z: np.ndarray, y: np.ndarray, coef: np.ndarray, confidence: float
) -> Intervals:
    """Autocovariance intervals of ``coef`` (non-zero on the selected support), the OLS fit of
    ``y`` on those columns of ``Z``; rows in time order (logs joined, as the polynomial family
    does: a join adds a few wrong lag products, negligible on logs much longer than the window)."""
    from scipy import stats

    support = np.flatnonzero(coef)
    residual = y - Z[:, support] @ coef[support]
    gamma, window, tau = residual_correlation(residual)
    p = coef.size
    std_err, ci = np.full(p, np.nan), np.full((p, 2), np.nan)
    if support.size == 0:
        return Intervals(std_err, ci, tau, window, None, np.zeros((0, 0)))
    lags = window if window is not None else gamma.size - 1
    cov = autocov_covariance(Z[:, support], gamma[: lags + 1])
    n = y.size
    df = float(max(min(n - support.size, n / (2 * lags + 1)), 1.0))
    std_err[support] = np.sqrt(np.diag(cov))
    half = stats.t.ppf(0.5 + confidence / 2, df) * std_err[support]
    ci[support] = np.column_stack([coef[support] - half, coef[support] + half])
    return Intervals(std_err, ci, tau, window, df, cov)


def percentile_intervals(ensemble: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """``(std_err, ci)`` of a bootstrap ensemble (models x terms): its spread and percentile
    interval, zeros included."""
    tail = (1 - confidence) / 2
    ci = np.quantile(ensemble, [tail, 1 - tail], axis=0).T
    return ensemble.std(axis=0, ddof=1), ci


def note(method: str, confidence: float, tau_int: float, window: int | None) -> IntervalNote:
    """What the coefficient intervals are, for the table's columns."""
    if method == "bootstrap":
        return IntervalNote(confidence, "blocked-bootstrap percentile", tau_int)
    return IntervalNote(
        confidence, "OLS + autocovariance sandwich, given the support", tau_int,
        SINDY_CALIBRATED_TAU, "benchmarks/bench_calibration_sindy.py", window is not None,
    )  # fmt: skip


def describe(
    method: str,
    confidence: float,
    n_models: int,
    tau_int: float,
    window: int | None,
    df: float | None,
) -> str:
    """One line for reports: the intervals' level, method and calibration for a fit."""
    level = f"{100 * confidence:g} % coefficient intervals"
    tau = f"residual correlation time {tau_int:.3g} rows"
    if method == "bootstrap":
        return (
            f"{level}: percentile intervals of the {n_models}-model blocked bootstrap at the "
            f"chosen threshold, zeros included ({tau}); where resamples pick other terms they are "
            "far wider than the estimates' spread (intervals: autocov, the default, is not)"
        )
    lags = "the lags examined" if window is None else f"±{window} lags"
    within = window is not None and tau_int <= SINDY_CALIBRATED_TAU
    t = "" if df is None else f", t with {df:.0f} df"
    return (
        f"{level}: OLS refit on the selected terms, covariance from the residual's "
        f"autocovariance over {lags}{t}. Conditional on the selected support: they do not count "
        "the chance that other terms should have been selected (the inclusion column answers "
        "that). Measured calibrated for residual correlation times up to "
        f"{SINDY_CALIBRATED_TAU:g} rows (benchmarks/bench_calibration_sindy.py, the support "
        "cross-validated among those of the path and the bootstrap); this fit: "
        f"{tau_int:.3g} rows, {'within' if within else 'BEYOND'} that range"
    )
