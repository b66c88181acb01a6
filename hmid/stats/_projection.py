"""A fitted residual's autocovariance, corrected for what the fit took out of the errors.

A least-squares residual is the errors with their projection on the regressors removed,
``r = (I - H) e``. Each regressor that varies slowly against the errors' correlation takes with it
the errors' slow part, so every lag of the residual's sample autocovariance reads low by about
the same amount, ``E[gamma_k(r)] ~ gamma_k - lrv h_k / n`` (``lrv`` the errors' long-run
variance, the sum of their autocovariance over all lags; ``h_k = tr(H D_k)`` the trace of the
hat matrix shifted by k rows, ``p`` at lag 0). Summed over a window of 2M + 1 lags the deficit is
``lrv H(M) / n``, ``H(M) = sum_{|k| <= M} h_k``, about ``p (2M + 1) / n`` of the long-run
variance: negligible on 20,000 rows, but on 3,000 rows with 16 terms and a window of 60 lags a
third of it. Sokal's window closes early on the dragged-down tau(M), and the sandwich built from
it is too narrow (a cubic polynomial on 3 s of AR(1) phi 0.97 noise read tau_int 32 for 66).

:func:`fitted_correlation` undoes that: ``lrv(M) = S(M) / (1 - H(M) / n)`` with ``S(M)`` the
residual's autocovariance summed over the window, each lag raised by ``lrv(M) h_k / n``, Sokal's
window found on the corrected tau(M). For white errors the correction is exact (the residual's
covariance is then ``sigma² (I - H)``); for correlated ones it assumes the regressors vary
slowly against the errors' correlation, and reads a little wide for fast ones. Where the fit's
projection would hold half the window's information or more (``H(M) >= n / 2``), a lag window
cannot be read from these rows: the window is left open (None). The ``h_k`` are one pass over the
design by blocks of rows (a cross-correlation of the design with ``X (X'X)^-1`` in the frequency
domain), about the cost of the sandwich's own.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from hmid._blas import one_blas_thread
from hmid.stats._autocorrelation import residual_correlation

if TYPE_CHECKING:
    from hmid.models._lstsq import RowBlocks

#: Share of a window's information the fit's projection may take before no window is read.
PROJECTION_LIMIT = 0.5
#: Rows per block of the lag traces' frequency-domain sum.
TRACE_BLOCK = 32_768
#: Lags of the first pass of the lag traces (a window of 5 tau_int for tau_int up to 50).
FIRST_LAGS = 256


@dataclass(frozen=True)
class FittedCorrelation:
    """A fitted residual's autocovariance ``gamma`` (lags 0..M, corrected for the fit's
    projection), Sokal's ``window`` M (None: it does not close within the lags examined or
    before the projection takes half the window), ``tau_int`` (corrected; at an open window the
    last value reached, a lower bound), ``raw_tau_int`` (the residual's own, as
    :func:`residual_correlation` reads it), ``n_eff`` = n / tau_int, and the design's transform
    where it was one block (``spectrum=`` of :func:`hmid.stats.autocov_covariance`)."""

    gamma: np.ndarray
    window: int | None
    tau_int: float
    raw_tau_int: float
    n_eff: float
    #: ``(size, rfft(X, size))`` of a design of one block, for :func:`autocov_covariance`
    spectrum: tuple[int, np.ndarray] | None = field(default=None, repr=False, compare=False)

    def dof(self, p: int) -> float:
        """Degrees of freedom of a t interval on ``p`` coefficients: n_eff - p, at least 1."""
        return max(self.n_eff - p, 1.0)


def lag_traces(
    exog: np.ndarray | RowBlocks,
    bread: np.ndarray,
    lags: int,
    block: int = TRACE_BLOCK,
    spectrum: tuple[int, np.ndarray] | None = None,
) -> np.ndarray:
    """``h_k = tr(H D_k) = sum_t x_t' (X'X)^-1 x_{t+k}`` for k = 0..lags, ``bread`` = (X'X)^-1,
    by blocks of ``block`` rows in the frequency domain: with ``bread = F F'``, ``H = U U'`` for
    ``U = X F``, and h_k is the summed autocorrelation of U's columns (one transform of a block
    that reaches the last row, two of any other: it and the rows ``lags`` past it). ``spectrum``
    ``(size, rfft(X, size))`` of the whole design, size >= n + lags, replaces the passes (U's
    transform is X's times F)."""
    from scipy import fft

    n = exog.shape[0]
    if spectrum is not None:
        size, transform = spectrum
        if size < n + lags:
            raise ValueError(f"lag_traces: a spectrum of {size} points holds no {lags} lags")
        # |F_X f_j|² summed over j is Re(F_X B F_X^H) on the diagonal: in real arithmetic, the
        # transform viewed as rows of (re, im) pairs (a zgemm would cost twice as much), laid
        # out as one 2m x p matrix so that it is one gemm, not m small ones (half the time)
        p = transform.shape[1]
        pairs = np.ascontiguousarray(transform).view(float)  # m x 2p: re, im per column
        parts = np.ascontiguousarray(pairs.reshape(-1, p, 2).transpose(0, 2, 1)).reshape(-1, p)
        with one_blas_thread():
            power = ((parts @ bread) * parts).reshape(-1, 2 * p).sum(axis=1)
        return fft.irfft(power, size)[: lags + 1]
    w, v = np.linalg.eigh(bread)
    factor = v * np.sqrt(np.maximum(w, 0.0))
    total = np.zeros(lags + 1)
    for start in range(0, n, block):
        stop = min(start + block, n)
        ahead = min(stop + lags, n)
        size = fft.next_fast_len(ahead - start + lags, real=True)
        with one_blas_thread():
            around = np.asarray(exog[start:ahead]) @ factor  # the block and the lags past it
            later = fft.rfft(around, n=size, axis=0)
            if ahead == stop:  # the block is all there is to pair with: a power spectrum
                power = later.real**2 + later.imag**2
            else:
                rows = fft.rfft(around[: stop - start], n=size, axis=0)
                power = np.conj(rows) * later
            total += fft.irfft(power.sum(axis=1), size)[: lags + 1]
    return total


def fitted_correlation(
    residual: np.ndarray, exog: np.ndarray | RowBlocks, bread: np.ndarray, c: float = 5.0
) -> FittedCorrelation:
    """The least-squares ``residual``'s autocovariance corrected for the projection on
    ``exog`` (``bread`` = (X'X)^-1), Sokal's window on the corrected tau(M) (see the module
    docstring); lags up to n/10, as :func:`residual_correlation`. The lag traces are computed
    to :data:`FIRST_LAGS` lags, doubled until the window closes: a pass over the design holds
    one block of rows and its lags, never n/10 lags of a long log unless the window needs them."""
    n = residual.size
    gamma, _, raw = residual_correlation(residual, c)
    if not gamma[0] > 0:  # an exact fit
        return FittedCorrelation(gamma[:1], 0, 1.0, 1.0, float(n))
    most = gamma.size - 1
    spectrum = None
    if n <= TRACE_BLOCK:  # one transform of the design, for every pass and the sandwich
        from scipy import fft

        size = fft.next_fast_len(n + most, real=True)
        with one_blas_thread():
            spectrum = (size, fft.rfft(np.asarray(exog[0:n]), n=size, axis=0))
    # the transform gives every lag at once; passes by blocks, only the lags the window needs
    lags = most if spectrum is not None else min(FIRST_LAGS, most)
    while True:
        h = lag_traces(exog, bread, lags, spectrum=spectrum)
        summed = gamma[0] + 2.0 * np.concatenate([[0.0], np.cumsum(gamma[1 : lags + 1])])
        taken = (h[0] + 2.0 * np.concatenate([[0.0], np.cumsum(h[1:])])) / n
        readable = taken < PROJECTION_LIMIT
        lrv = summed / np.where(readable, 1.0 - taken, 1.0)
        taus = np.maximum(lrv / (gamma[0] + lrv * h[0] / n), 1.0)
        closed = readable & (np.arange(taus.size) >= c * taus)
        if closed.any() or not readable[-1] or lags == most:
            break
        lags = min(2 * lags, most)
    last = int(np.flatnonzero(readable)[-1]) if readable.any() else 0
    window = int(np.argmax(closed)) if closed.any() else None
    m = last if window is None else window
    corrected = gamma[: m + 1] + lrv[m] * h[: m + 1] / n
    tau = float(taus[m])
    return FittedCorrelation(corrected, window, tau, float(raw), n / tau, spectrum)
