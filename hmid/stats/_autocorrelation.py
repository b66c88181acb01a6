"""How long a residual stays correlated: its autocorrelation and integrated autocorrelation time.

Two estimators of the autocorrelation, for two kinds of record:

* :func:`autocorrelation` reads a residual *over log segments*: samples of different segments and
  rows left out (validation, a margin) are never paired, each lag divided by the pairs it has
  (statsmodels' ``acf(adjusted=True, missing="conservative")``). The balance and the loop use it:
  their rows carry the segments (:class:`Segmented`).
* :func:`residual_correlation` reads a residual as *one record in row order* (the families join
  their logs: a join adds a few wrong lag products, negligible on logs much longer than the
  window), as the biased sample autocovariance (divided by n), which is positive semi-definite so
  that its Bartlett taper is too (:func:`hmid.stats.autocov_covariance` relies on that).

Both end in Sokal's automatic window (:func:`sokal_window`, emcee's ``auto_window``): tau_int =
1 + 2 sum rho_k summed up to the first lag M >= c tau(M), short enough that the noisy far lags do
not swamp it, long enough to hold the correlation. ``n / tau_int`` is the residual's effective
sample size.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol

import numpy as np


class Segmented(Protocol):
    """Rows in log segments (a :class:`hmid.balance.Signals`): the row indices of each segment,
    the sampling step and the training rows."""

    @property
    def dt(self) -> float: ...

    @property
    def train(self) -> np.ndarray: ...

    def segments(self) -> Iterable[np.ndarray]: ...


def lag_count(segmented: Segmented, seconds: float, minimum: int = 2) -> int:
    """``seconds`` in samples at the median step of the first segment."""
    return max(round(seconds / segmented.dt), minimum)


def masked_series(
    values: np.ndarray, rows: np.ndarray, segmented: Segmented, gap: int
) -> np.ndarray:
    """``values`` where ``rows``, NaN elsewhere, with ``gap`` NaNs between segments, so that
    lagged products never pair samples of different segments or left-out rows."""
    parts = []
    for seg in segmented.segments():
        parts.append(np.where(rows[seg], values[seg], np.nan))
        parts.append(np.full(gap, np.nan))
    return np.concatenate(parts)


def autocorrelation(
    values: np.ndarray, rows: np.ndarray, segmented: Segmented, nlags: int
) -> np.ndarray:
    """ACF at lags 0..nlags of ``values`` over ``rows``, each lag over the pairs where both
    samples are present in one segment (statsmodels' ``acf(adjusted=True,
    missing="conservative")``, by FFT)."""
    from scipy.signal import correlate

    series = masked_series(values - np.mean(values[rows]), rows, segmented, nlags)
    present = np.isfinite(series)
    filled = np.where(present, series, 0.0)
    n = len(series)
    products = correlate(filled, filled, mode="full", method="fft")[n - 1 : n + nlags]
    pairs = correlate(present.astype(float), present.astype(float), mode="full", method="fft")
    acov = products / np.maximum(np.rint(pairs[n - 1 : n + nlags]), 1.0)
    return acov / acov[0]


def sokal_window(acf: np.ndarray, c: float = 5.0) -> tuple[int | None, float]:
    """``(M, tau_int)``: Sokal's window, the first lag M >= c tau(M) with tau(M) = 1 + 2 sum
    rho_k up to M (emcee's ``auto_window``), and tau_int there, at least 1. A window that never
    closes gives M None and the last lag's value: a lower bound."""
    taus = 2.0 * np.cumsum(acf) - 1.0
    open_ = np.arange(taus.size) < c * taus
    window = None if open_.all() else int(np.argmin(open_))
    return window, float(max(taus[-1 if window is None else window], 1.0))


def integrated_time(acf: np.ndarray, c: float = 5.0) -> float:
    """tau_int at Sokal's window (:func:`sokal_window`)."""
    return sokal_window(acf, c)[1]


def residual_tau_int(
    residual: np.ndarray, segmented: Segmented, rows: np.ndarray | None = None
) -> float:
    """Integrated autocorrelation time (samples) of the residual on ``rows`` (default: the
    training rows, ``segmented.train``), over segments, with lags up to 10 s."""
    rows = segmented.train if rows is None else rows
    nlags = acf_lags(segmented, rows)
    return integrated_time(autocorrelation(residual, rows, segmented, nlags))


def acf_lags(segmented: Segmented, rows: np.ndarray) -> int:
    """The lags a segmented residual's autocorrelation is read to: 10 s, at most a twentieth of
    the rows."""
    return min(lag_count(segmented, 10.0), max(int(rows.sum()) // 20, 2))


def residual_correlation(
    residual: np.ndarray, c: float = 5.0
) -> tuple[np.ndarray, int | None, float]:
    """``(autocovariance at lags 0..n/10, Sokal's window M or None, tau_int)`` of a residual in
    row order, one record (the biased sample autocovariance, divided by n); a window that never
    closes gives None and the last lag's value, a lower bound."""
    from scipy import fft

    # statsmodels' acovf(adjusted=False, demean=False, fft=True), to rounding, at a quarter of
    # its cost: every fit of every family measures its residual's correlation
    n, lags = residual.size, max(residual.size // 10, 1)
    # padded past the last lag, not to 2n: the circular correlation is the linear one up there
    size = fft.next_fast_len(n + lags, real=True)
    spectrum = fft.rfft(residual, size)
    # the power spectrum written over the spectrum, as a complex array with zero imaginary
    # parts: irfft would copy a real one to complex (a long residual's transforms are the fit's
    # largest arrays, so they are held one at a time)
    power, imag = spectrum.real, spectrum.imag
    np.square(power, out=power)
    power += np.square(imag, out=imag)
    imag[...] = 0.0
    del power, imag
    gamma = fft.irfft(spectrum, size, overwrite_x=True)[: lags + 1] / n
    del spectrum
    if not gamma[0] > 0:  # an exact fit
        return gamma, 0, 1.0
    window, tau = sokal_window(gamma / gamma[0], c)
    return gamma, window, tau
