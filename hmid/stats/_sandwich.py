"""Covariance of least-squares coefficients on errors correlated in time: sandwich estimators.

OLS's ``sigma² (X'X)^-1`` assumes independent errors; a 1 kHz residual is far from that (the
smoothing both sides of a balance share, sensor quantisation, slow unmodelled structure). The
sandwich ``(X'X)^-1 X' S X (X'X)^-1`` holds for any error covariance ``S``:

* :func:`autocov_covariance` takes ``S`` Toeplitz in the residual's own autocovariance up to
  Sokal's window (:mod:`hmid.stats._autocorrelation`), zero beyond, either over one record in row
  order or within log segments. A truncated autocovariance need not be positive definite; where
  it leaves a variance <= 0, its Bartlett-tapered version (positive semi-definite) takes over.
  Calibrated per family by ``benchmarks/bench_calibration_*.py``; an n/tau_int inflation of OLS
  errors, used before, is exact only for slowly varying regressors and 1.2-1.7x too wide for
  fast ones.
* :func:`hac_covariance` is Newey-West's (Bartlett weights at every lag up to :func:`hac_lags`),
  the polynomial family's opt-in ``errors="hac"``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from hmid._blas import one_blas_thread
from hmid.stats._autocorrelation import Segmented

if TYPE_CHECKING:
    from hmid.models._lstsq import RowBlocks

#: Rows per block of the row-order sandwich's frequency-domain sum.
SANDWICH_BLOCK = 32_768


def autocov_covariance(
    exog: np.ndarray | RowBlocks,
    gamma: np.ndarray,
    bread: np.ndarray | None = None,
    block: int = SANDWICH_BLOCK,
    *,
    rows: np.ndarray | None = None,
    segmented: Segmented | None = None,
    spectrum: tuple[int, np.ndarray] | None = None,
) -> np.ndarray:
    """Covariance of OLS coefficients under stationary errors of autocovariance ``gamma`` (lags
    0..M, zero beyond), independent of the regressors: ``(X'X)^-1 X' S X (X'X)^-1`` with ``S`` the
    Toeplitz matrix of ``gamma``, scaled by n/(n - p) like OLS's. ``bread`` is ``(X'X)^-1`` if
    known.

    In row order (``segmented`` None), ``exog``'s rows are one record; ``X' S X`` is summed in
    the frequency domain (Parseval: one real FFT of the design, zero-padded past M so that the
    circular convolution is the linear one), over blocks of ``block`` rows so that no second
    n x p array is held; ``spectrum`` ``(size, rfft(exog, size))``, size >= n + M, is the
    design's transform where it is one block (:class:`hmid.stats.FittedCorrelation` holds it).
    Over segments, ``exog`` holds every row of ``segmented`` and ``rows``
    (boolean) those fitted; ``S`` is zero across segments and left-out rows, and ``X' S X`` is
    the masked columns times their overlap-add convolution with ``gamma``."""
    if segmented is None:
        n, p = exog.shape
        if bread is None:
            X = np.asarray(exog)
            bread = np.linalg.pinv(X.T @ X)
        meat = _row_meat(exog, gamma.size - 1, block, spectrum)
    else:
        if rows is None or bread is None:
            raise ValueError("autocov_covariance: segmented= needs rows= and bread= as well")
        n, p = int(rows.sum()), exog.shape[1]
        meat = _segment_meat(np.asarray(exog), rows, segmented, gamma.size - 1)

    def sandwich(g: np.ndarray) -> np.ndarray:
        return bread @ meat(g) @ bread * (n / max(n - p, 1))

    cov = sandwich(gamma)
    if np.all(np.diag(cov) > 0):
        return cov
    return sandwich(gamma * (1.0 - np.arange(gamma.size) / gamma.size))


def _segment_meat(
    X: np.ndarray, rows: np.ndarray, segmented: Segmented, lags: int
) -> Callable[[np.ndarray], np.ndarray]:
    """``g -> X' S X`` over ``rows``, ``S`` Toeplitz in ``g`` within each segment, by FFT
    convolution of the masked columns (each segment followed by ``lags`` zero rows)."""
    from scipy.signal import oaconvolve

    masked = np.concatenate(
        [part for seg in segmented.segments()
         for part in (np.where(rows[seg, None], X[seg], 0.0), np.zeros((lags, X.shape[1])))]
    )  # fmt: skip

    def meat(g: np.ndarray) -> np.ndarray:
        kernel = np.concatenate([g[:0:-1], g])[:, None]
        filtered = oaconvolve(masked, kernel, mode="same", axes=0)
        return masked.T @ filtered

    return meat


def _row_meat(
    exog: np.ndarray | RowBlocks,
    lags: int,
    block: int,
    spectrum: tuple[int, np.ndarray] | None = None,
) -> Callable[[np.ndarray], np.ndarray]:
    """``g -> X' S X`` for ``exog``'s rows as one record, summed by blocks in the frequency
    domain (a design of one block: its ``spectrum`` if given)."""
    from scipy import fft

    n, p = exog.shape
    whole = spectrum if spectrum is not None and n <= block and spectrum[0] >= n + lags else None

    def meat(g: np.ndarray) -> np.ndarray:
        total = np.zeros((p, p))
        for start in range(0, n, block):
            stop = min(start + block, n)
            lo, hi = max(start - lags, 0), min(stop + lags, n)
            # rows lo..hi hold every row within M of a row of start..stop
            size = fft.next_fast_len(hi - lo + lags, real=True)
            if whole is not None:  # the design's transform, one block of enough points
                size = whole[0]
            kernel = np.zeros(size)
            kernel[: lags + 1], kernel[size - lags :] = g, g[:0:-1]
            weight = fft.rfft(kernel).real * 2.0  # the half spectrum counts twice ...
            weight[0] /= 2.0  # ... but for the mean
            if size % 2 == 0:
                weight[-1] /= 2.0  # and the Nyquist bin
            # one BLAS thread: on a busy machine OpenBLAS's threads made such thin products
            # 1000x slower (0.6 s instead of 0.6 ms for 20,000 x 16)
            with one_blas_thread():
                if whole is not None:
                    around = whole[1]
                else:
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
                total += (both[0::2, 0::2] + both[1::2, 1::2]) / size
        return total

    return meat


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
