"""Interval methods for least-squares coefficients on errors correlated in row order.

:func:`residual_correlation` measures how long a residual stays correlated (Sokal's window, as
emcee does for chains); :func:`autocov_covariance` is the OLS covariance under that correlation
(the sandwich with the residual's Toeplitz autocovariance); :func:`hac_lags` is the Newey-West
lag window of the opt-in ``errors="hac"``.
"""

from __future__ import annotations

import numpy as np


def residual_correlation(
    residual: np.ndarray, c: float = 5.0
) -> tuple[np.ndarray, int | None, float]:
    """``(autocovariance at lags 0..n/10, Sokal's window M or None, tau_int)`` of a residual in
    row order: tau_int = 1 + 2 sum rho_k up to the first lag M >= c tau(M) (emcee's
    ``auto_window``); a window that never closes gives None and the last lag's value, a lower
    bound."""
    from statsmodels.tsa.stattools import acovf

    n = residual.size
    gamma = acovf(residual, adjusted=False, demean=False, fft=True, nlag=max(n // 10, 1))
    if not gamma[0] > 0:  # an exact fit
        return gamma, 0, 1.0
    taus = 2.0 * np.cumsum(gamma / gamma[0]) - 1.0
    open_ = np.arange(taus.size) < c * taus
    window = None if open_.all() else int(np.argmin(open_))
    tau = taus[-1 if window is None else window]
    return gamma, window, float(max(tau, 1.0))


def autocov_covariance(exog: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """Covariance of OLS coefficients under stationary errors of autocovariance ``gamma`` (lags
    0..M, zero beyond), independent of the regressors: ``(X'X)^-1 X' S X (X'X)^-1`` with ``S`` the
    Toeplitz matrix of ``gamma`` (``S X`` by FFT convolution, O(n p log M)), scaled by n/(n - p)
    like OLS's. A truncated autocovariance need not be positive definite; where it leaves a
    variance <= 0, its Bartlett-tapered version (positive semi-definite for the biased sample
    autocovariance that :func:`residual_correlation` returns) takes over."""
    from scipy.signal import oaconvolve
    from threadpoolctl import threadpool_limits

    n, p = exog.shape
    bread = np.linalg.pinv(exog.T @ exog)

    def sandwich(g: np.ndarray) -> np.ndarray:
        kernel = np.concatenate([g[:0:-1], g])
        filtered = oaconvolve(exog, kernel[:, None], mode="same", axes=0)
        # one BLAS thread: this tall, thin product is memory-bound, and on a busy machine
        # OpenBLAS's threads made it 1000x slower (0.6 s instead of 0.6 ms for 20,000 x 16)
        with threadpool_limits(limits=1, user_api="blas"):
            meat = exog.T @ filtered
        return bread @ meat @ bread * (n / max(n - p, 1))

    cov = sandwich(gamma)
    if np.all(np.diag(cov) > 0):
        return cov
    return sandwich(gamma * (1.0 - np.arange(gamma.size) / gamma.size))


def hac_lags(residual: np.ndarray) -> int:
    """Newey-West lag window: the first lag at which the residual autocorrelation falls inside
    its white-noise band 2/sqrt(n), at least the usual 4 (n/100)^(2/9), at most n/10."""
    from statsmodels.tsa.stattools import acf

    n = residual.size
    floor = max(1, int(4 * (n / 100) ** (2 / 9)))
    cap = max(floor, n // 10)
    rho = acf(residual, nlags=min(cap, n - 1), fft=True)
    inside = np.flatnonzero(np.abs(rho[1:]) < 2 / np.sqrt(n))
    first = int(inside[0]) + 1 if inside.size else cap
    return int(min(cap, max(floor, first)))
