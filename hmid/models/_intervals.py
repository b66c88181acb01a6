"""Interval methods for least-squares coefficients on errors correlated in row order.

:func:`residual_correlation` measures how long a residual stays correlated (Sokal's window, as
emcee does for chains); :func:`autocov_covariance` is the OLS covariance under that correlation
(the sandwich with the residual's Toeplitz autocovariance); :func:`hac_lags` is the Newey-West
lag window of the opt-in ``errors="hac"``.
"""

from __future__ import annotations

from functools import cache

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


@cache
def _controller():
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()  # finding the loaded libraries costs ~3 ms: once


def one_blas_thread():
    """A context in which BLAS runs one thread (``threadpoolctl``, its libraries found once)."""
    return _controller().limit(limits=1, user_api="blas")


def autocov_covariance(
    exog: np.ndarray, gamma: np.ndarray, bread: np.ndarray | None = None, block: int = 32_768
) -> np.ndarray:
    """Covariance of OLS coefficients under stationary errors of autocovariance ``gamma`` (lags
    0..M, zero beyond), independent of the regressors: ``(X'X)^-1 X' S X (X'X)^-1`` with ``S`` the
    Toeplitz matrix of ``gamma`` (``S X`` by FFT convolution, O(n p log M), over blocks of
    ``block`` rows so that no second n x p matrix is held), scaled by n/(n - p) like OLS's.
    ``bread`` is ``(X'X)^-1`` if known. A truncated autocovariance need not be positive definite;
    where it leaves a variance <= 0, its Bartlett-tapered version (positive semi-definite for the
    biased sample autocovariance that :func:`residual_correlation` returns) takes over."""
    from scipy.signal import oaconvolve

    n, p = exog.shape
    if bread is None:
        bread = np.linalg.pinv(exog.T @ exog)

    def sandwich(g: np.ndarray) -> np.ndarray:
        kernel = np.concatenate([g[:0:-1], g])[:, None]
        lags, meat = g.size - 1, np.zeros((p, p))
        for start in range(0, n, block):
            stop = min(start + block, n)
            lo, hi = max(start - lags, 0), min(stop + lags, n)
            # rows lo..hi reach every row that the kernel centred on start..stop touches
            full = oaconvolve(exog[lo:hi], kernel, mode="full", axes=0)
            filtered = full[start - lo + lags : stop - lo + lags]
            # one BLAS thread: this tall, thin product is memory-bound, and on a busy machine
            # OpenBLAS's threads made it 1000x slower (0.6 s instead of 0.6 ms for 20,000 x 16)
            with one_blas_thread():
                meat += exog[start:stop].T @ filtered
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


def hac_covariance(exog: np.ndarray, y: np.ndarray, lags: int, has_const: bool) -> np.ndarray:
    """Newey-West covariance of the OLS coefficients (statsmodels, ``lags`` lags)."""
    from statsmodels.regression.linear_model import OLS

    fit = OLS(y, exog, hasconst=has_const).fit(cov_type="HAC", cov_kwds={"maxlags": lags})
    return np.asarray(fit.cov_params())
