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
    from scipy import fft

    # statsmodels' acovf(adjusted=False, demean=False, fft=True), to rounding, at a quarter of
    # its cost: every fit of every family measures its residual's correlation
    n, lags = residual.size, max(residual.size // 10, 1)
    # padded past the last lag, not to 2n: the circular correlation is the linear one up there
    size = fft.next_fast_len(n + lags, real=True)
    spectrum = fft.rfft(residual, size)
    power = spectrum.real**2
    power += spectrum.imag**2
    del spectrum  # a long residual's transforms are the fit's largest arrays: one at a time
    gamma = fft.irfft(power, size, overwrite_x=True)[: lags + 1] / n
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
    Toeplitz matrix of ``gamma``, scaled by n/(n - p) like OLS's. ``X' S X`` is summed in the
    frequency domain (Parseval: one real FFT of the design, zero-padded past M so that the
    circular convolution is the linear one), over blocks of ``block`` rows so that no second
    n x p array is held. ``bread`` is ``(X'X)^-1`` if known. A truncated autocovariance need not
    be positive definite; where it leaves a variance <= 0, its Bartlett-tapered version
    (positive semi-definite for the biased sample autocovariance that
    :func:`residual_correlation` returns) takes over."""
    from scipy import fft

    n, p = exog.shape
    if bread is None:
        bread = np.linalg.pinv(exog.T @ exog)
    lags = gamma.size - 1

    def sandwich(g: np.ndarray) -> np.ndarray:
        meat = np.zeros((p, p))
        for start in range(0, n, block):
            stop = min(start + block, n)
            lo, hi = max(start - lags, 0), min(stop + lags, n)
            # rows lo..hi hold every row within M of a row of start..stop
            size = fft.next_fast_len(hi - lo + lags, real=True)
            kernel = np.zeros(size)
            kernel[: lags + 1], kernel[size - lags :] = g, g[:0:-1]
            weight = fft.rfft(kernel).real * 2.0  # the half spectrum counts twice ...
            weight[0] /= 2.0  # ... but for the mean
            if size % 2 == 0:
                weight[-1] /= 2.0  # and the Nyquist bin
            # one BLAS thread: on a busy machine OpenBLAS's threads made such thin products
            # 1000x slower (0.6 s instead of 0.6 ms for 20,000 x 16)
            with one_blas_thread():
                around = fft.rfft(exog[lo:hi], n=size, axis=0)
                if (lo, hi) == (start, stop):
                    inside = around
                else:
                    rows = np.zeros((hi - lo, p))
                    rows[start - lo : stop - lo] = exog[start:stop]
                    inside = fft.rfft(rows, n=size, axis=0)
                # Re(A^H W B) in real arithmetic: the spectra viewed as interleaved re, im
                spectrum = np.ascontiguousarray(around).view(float)
                other = spectrum if inside is around else np.ascontiguousarray(inside).view(float)
                both = (other * weight[:, None]).T @ spectrum
                meat += (both[0::2, 0::2] + both[1::2, 1::2]) / size
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
