"""Statistics of correlated residuals: autocorrelation over gappy segments, the integrated
autocorrelation time, and parameter intervals under that correlation.

A 1 kHz residual is far from independent (the smoothing that both sides of the balance share,
sensor quantisation, slow unmodelled structure). Coefficient intervals use the OLS sandwich with
the residual's autocovariance up to Sokal's window (:func:`inference`); tests and likelihood
intervals count ``n_eff = n / tau_int`` samples, ``tau_int`` the integrated autocorrelation time.
An n/tau_int inflation of OLS errors, used before, is exact only for slowly varying regressors
and 1.2-1.7x too wide for fast ones.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from hmid.balance.columns import Columns
from hmid.balance.signals import Signals

#: The longest residual correlation time (samples) at which :func:`inference` was calibrated:
#: AR(1) phi = 0.97 in benchmarks/bench_calibration_balance.py (95 % coverage 0.966).
CALIBRATED_TAU = 66.0


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


def sokal_window(acf: np.ndarray, c: float = 5.0) -> tuple[int, float]:
    """``(M, tau_int)``: Sokal's window, the first lag M >= c tau(M) with tau(M) = 1 + 2 sum
    rho_k up to M (as emcee's ``auto_window``), and tau_int there; a window that never closes
    gives the last lag and its value, a lower bound."""
    taus = 2.0 * np.cumsum(acf) - 1.0
    open_ = np.arange(len(taus)) < c * taus
    window = int(np.argmin(open_)) if not open_.all() else len(taus) - 1
    return window, float(max(taus[window], 1.0))


def integrated_time(acf: np.ndarray, c: float = 5.0) -> float:
    """tau_int at Sokal's window (:func:`sokal_window`)."""
    return sokal_window(acf, c)[1]


def residual_tau_int(
    residual: np.ndarray, signals: Signals, rows: np.ndarray | None = None
) -> float:
    """Integrated autocorrelation time of the residual on ``rows`` (default: training rows),
    with lags up to 10 s."""
    rows = signals.train if rows is None else rows
    nlags = min(lag_count(signals, 10.0), max(int(rows.sum()) // 20, 2))
    return integrated_time(autocorrelation(residual, rows, signals, nlags))


def inference(
    columns: Columns, y: np.ndarray, rows: np.ndarray, signals: Signals, confidence: float
) -> pd.DataFrame:
    """OLS (statsmodels) of ``y`` on ``columns`` over ``rows``, with the covariance of
    correlated errors: the sandwich with the residual's autocovariance up to Sokal's window,
    lag products taken within segments only, t intervals on n / (2 M + 1) degrees of freedom
    (as the polynomial family's default; calibrated by
    ``benchmarks/bench_calibration_balance.py``)."""
    import statsmodels.api as sm

    X = columns.values[rows]
    scale = np.max(np.abs(X), axis=0)
    scale[scale == 0] = 1.0
    fit = sm.OLS(y[rows], X / scale).fit()
    n, p = X.shape
    residual = np.zeros(len(y))
    residual[rows] = fit.resid
    nlags = min(lag_count(signals, 10.0), max(int(rows.sum()) // 20, 2))
    acf = autocorrelation(residual, rows, signals, nlags)
    window, _ = sokal_window(acf)
    gamma = acf[: window + 1] * float(np.mean(fit.resid**2))
    cov = _segment_sandwich(columns.values / scale, rows, signals, gamma, fit.normalized_cov_params)
    value = np.asarray(fit.params) / scale
    se = np.sqrt(np.maximum(np.diag(cov), 0.0)) / scale
    df = max(min(n - p, n / (2 * window + 1)), 1.0)
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


def _segment_sandwich(
    X: np.ndarray, rows: np.ndarray, signals: Signals, gamma: np.ndarray, bread: np.ndarray
) -> np.ndarray:
    """``B X' S X B`` over ``rows``, ``S`` Toeplitz in ``gamma`` within each segment (zero
    across segments and left-out rows), by FFT convolution of the masked columns; scaled by
    n/(n - p). Where the truncated autocovariance leaves a variance <= 0, its Bartlett-tapered
    (positive semi-definite) version is used."""
    from scipy.signal import oaconvolve

    lags = gamma.size - 1
    masked = np.concatenate(
        [part for seg in signals.segments()
         for part in (np.where(rows[seg, None], X[seg], 0.0), np.zeros((lags, X.shape[1])))]
    )  # fmt: skip
    n, p = int(rows.sum()), X.shape[1]

    def sandwich(g: np.ndarray) -> np.ndarray:
        kernel = np.concatenate([g[:0:-1], g])[:, None]
        filtered = oaconvolve(masked, kernel, mode="same", axes=0)
        return bread @ (masked.T @ filtered) @ bread * (n / max(n - p, 1))

    cov = sandwich(gamma)
    if np.all(np.diag(cov) > 0):
        return cov
    return sandwich(gamma * (1.0 - np.arange(gamma.size) / gamma.size))


def profile_interval(
    grid: np.ndarray, sse: np.ndarray, n_eff: float, confidence: float
) -> tuple[float, float]:
    """Grid values whose profile likelihood ratio n_eff ln(SSE/SSE_min) is within the chi²(1)
    quantile: a likelihood interval at the grid's resolution."""
    inside = n_eff * np.log(sse / sse.min()) <= stats.chi2.ppf(confidence, 1)
    return float(grid[inside].min()), float(grid[inside].max())
