"""Statistics of correlated residuals: autocorrelation over gappy segments, the integrated
autocorrelation time, and parameter intervals on the effective sample size.

A 1 kHz residual is far from independent (the smoothing that both sides of the balance share,
sensor quantisation, slow unmodelled structure), so intervals count ``n_eff = n / tau_int``
samples, ``tau_int`` being the integrated autocorrelation time of the residual with Sokal's
automatic window (as for MCMC chains). For slowly varying regressors this is the variance
inflation of least-squares coefficients; it is approximate (conservative for fast regressors).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from hmid.balance.columns import Columns
from hmid.balance.signals import Signals


def lag_count(signals: Signals, seconds: float, minimum: int = 2) -> int:
    """``seconds`` in samples at the median step of the first segment."""
    return max(round(seconds / signals.dt), minimum)


def masked_series(values: np.ndarray, rows: np.ndarray, signals: Signals, gap: int) -> np.ndarray:
    """``values`` where ``rows``, NaN elsewhere, with ``gap`` NaNs between segments, so that
    lagged products never pair samples of different segments or left-out rows."""
    parts = []
    for seg in signals.segments():
        parts.append(np.where(rows[seg], values[seg], np.nan))
        parts.append(np.full(gap, np.nan))
    return np.concatenate(parts)


def autocorrelation(
    values: np.ndarray, rows: np.ndarray, signals: Signals, nlags: int
) -> np.ndarray:
    """ACF at lags 0..nlags of ``values`` over ``rows``, each lag over the pairs where both
    samples are present (statsmodels' ``acf(adjusted=True, missing="conservative")``, by FFT)."""
    from scipy.signal import correlate

    series = masked_series(values - np.mean(values[rows]), rows, signals, nlags)
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


def residual_tau_int(
    residual: np.ndarray, signals: Signals, rows: np.ndarray | None = None
) -> float:
    """Integrated autocorrelation time of the residual on ``rows`` (default: training rows),
    with lags up to 10 s."""
    rows = signals.train if rows is None else rows
    nlags = min(lag_count(signals, 10.0), max(int(rows.sum()) // 20, 2))
    return integrated_time(autocorrelation(residual, rows, signals, nlags))


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
