"""Coefficient intervals of a balance fitted by least squares on a correlated residual.

The balance's coefficients are OLS on its columns over the training rows; their intervals use the
sandwich with the residual's autocovariance up to Sokal's window, lag products taken within log
segments only (:func:`hmid.stats.autocov_covariance`). The estimators themselves live in
:mod:`hmid.stats`; this module wires them to a balance's :class:`Columns` and :class:`Signals`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from hmid.balance.columns import Columns
from hmid.balance.signals import Signals
from hmid.stats import acf_lags, autocorrelation, autocov_covariance, sokal_window

#: The longest residual correlation time (samples) at which :func:`inference` was calibrated:
#: AR(1) phi = 0.97 in benchmarks/bench_calibration_balance.py (95 % coverage 0.966).
CALIBRATED_TAU = 66.0


def inference(
    columns: Columns, y: np.ndarray, rows: np.ndarray, signals: Signals, confidence: float
) -> pd.DataFrame:
    """OLS (statsmodels) of ``y`` on ``columns`` over ``rows``, with the covariance of
    correlated errors: the sandwich with the residual's autocovariance up to Sokal's window,
    lag products taken within segments only, t intervals on n / (2 M + 1) degrees of freedom
    (as the polynomial family's default; calibrated by
    ``benchmarks/bench_calibration_balance.py``)."""
    return sandwich(columns, y, rows, signals, confidence)[0]


def sandwich(
    columns: Columns, y: np.ndarray, rows: np.ndarray, signals: Signals, confidence: float
) -> tuple[pd.DataFrame, np.ndarray]:
    """:func:`inference`'s table and the coefficients' covariance it reads its standard errors
    from (in the columns' units): what a model file carries for draws of the coefficients."""
    import statsmodels.api as sm

    X = columns.values[rows]
    scale = np.max(np.abs(X), axis=0)
    scale[scale == 0] = 1.0
    fit = sm.OLS(y[rows], X / scale).fit()
    n, p = X.shape
    residual = np.zeros(len(y))
    residual[rows] = fit.resid
    acf = autocorrelation(residual, rows, signals, acf_lags(signals, rows))
    window, _ = sokal_window(acf)
    window = acf.size - 1 if window is None else window  # never closed: every lag read
    gamma = acf[: window + 1] * float(np.mean(fit.resid**2))
    cov = autocov_covariance(
        columns.values / scale, gamma, fit.normalized_cov_params, rows=rows, segmented=signals
    )
    value = np.asarray(fit.params) / scale
    se = np.sqrt(np.maximum(np.diag(cov), 0.0)) / scale
    df = max(min(n - p, n / (2 * window + 1)), 1.0)
    half = stats.t.ppf(0.5 + confidence / 2, df) * se
    table = pd.DataFrame(
        {
            "parameter": columns.names,
            "value": value,
            "std. error": se,
            "lower": value - half,
            "upper": value + half,
            "unit": columns.units,
        }
    )
    return table, cov / np.outer(scale, scale)
