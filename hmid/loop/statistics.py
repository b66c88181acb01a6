"""Statistics of correlated residuals: autocorrelation over gappy segments, the integrated
autocorrelation time, nested-model F-tests and parameter intervals on the effective sample size.

A 1 kHz residual is far from independent (smoothing filters, sensor quantisation, slow unmodelled
structure), so every test here counts ``n_eff = n / tau_int`` samples, ``tau_int`` being the
integrated autocorrelation time of the residual with Sokal's automatic window (as for MCMC
chains). For slowly varying regressors this is the variance inflation of least-squares
coefficients; it is approximate (and conservative for fast regressors), and the report says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

from hmid.loop.data import LoopData
from hmid.loop.design import Columns


def masked_series(values: np.ndarray, rows: np.ndarray, data: LoopData, gap: int) -> np.ndarray:
    """``values`` where ``rows``, NaN elsewhere, with ``gap`` NaNs between segments, so that
    lagged products never pair samples of different segments or left-out rows."""
    parts = []
    for seg in data.segments():
        parts.append(np.where(rows[seg], values[seg], np.nan))
        parts.append(np.full(gap, np.nan))
    return np.concatenate(parts)


def autocorrelation(values: np.ndarray, rows: np.ndarray, data: LoopData, nlags: int) -> np.ndarray:
    """ACF at lags 0..nlags of ``values`` over ``rows``, each lag over the pairs where both
    samples are present (statsmodels' ``acf(adjusted=True, missing="conservative")``, by FFT)."""
    from scipy.signal import correlate

    series = masked_series(values - np.mean(values[rows]), rows, data, nlags)
    present = np.isfinite(series)
    filled = np.where(present, series, 0.0)
    n = len(series)
    products = correlate(filled, filled, mode="full", method="fft")[n - 1 : n + nlags]
    pairs = correlate(present.astype(float), present.astype(float), mode="full", method="fft")
    acov = products / np.maximum(np.rint(pairs[n - 1 : n + nlags]), 1.0)
    return acov / acov[0]


def integrated_time(acf: np.ndarray, c: float = 5.0) -> float:
    """tau_int = 1 + 2 sum rho_k up to Sokal's window, the first M >= c tau(M) (as emcee's
    ``auto_window``, except that a window that never closes gives the last lag's value, a lower
    bound, rather than 0)."""
    taus = 2.0 * np.cumsum(acf) - 1.0
    open_ = np.arange(len(taus)) < c * taus
    window = int(np.argmin(open_)) if not open_.all() else len(taus) - 1
    return float(max(taus[window], 1.0))


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


def inference(
    columns: Columns, y: np.ndarray, rows: np.ndarray, tau_int: float, confidence: float
) -> pd.DataFrame:
    """OLS (statsmodels) of ``y`` on ``columns`` over ``rows``; standard errors inflated by
    sqrt(tau_int), t intervals on n_eff - p degrees of freedom."""
    import statsmodels.api as sm

    X = columns.values[rows]
    scale = np.max(np.abs(X), axis=0)
    scale[scale == 0] = 1.0
    fit = sm.OLS(y[rows], X / scale).fit()
    value = np.asarray(fit.params) / scale
    se = np.asarray(fit.bse) / scale * np.sqrt(tau_int)
    df = max(len(X) / tau_int - len(value), 1.0)
    half = stats.t.ppf(0.5 + confidence / 2, df) * se
    return pd.DataFrame(
        {
            "parameter": columns.names,
            "value": value,
            "std. error": se,
            "lower": value - half,
            "upper": value + half,
            "unit": columns.units,
        }
    )


def profile_interval(
    grid: np.ndarray, sse: np.ndarray, n_eff: float, confidence: float
) -> tuple[float, float]:
    """Grid values whose profile likelihood ratio n_eff ln(SSE/SSE_min) is within the chi²(1)
    quantile: a likelihood interval at the grid's resolution."""
    inside = n_eff * np.log(sse / sse.min()) <= stats.chi2.ppf(confidence, 1)
    return float(grid[inside].min()), float(grid[inside].max())
