"""Statistics of correlated errors, held once: every family, the balance, the friction stage and
the loop take them from here.

A 1 kHz residual is far from independent (the smoothing that both sides of a balance share,
sensor quantisation, slow unmodelled structure), so every interval and test in hmid counts its
correlation. The estimators, and why each:

* **autocorrelation and tau_int** (:mod:`._autocorrelation`, in the spirit of emcee's
  ``autocorr.py``): :func:`autocorrelation` over log segments (no lag product pairs two segments
  or a left-out row; the balance and the loop, whose rows are :class:`Segmented`) and
  :func:`residual_correlation` over one record in row order (the families, whose logs are
  joined); both sum the integrated autocorrelation time tau_int up to Sokal's automatic window
  (:func:`sokal_window`). ``n / tau_int`` is the effective sample size.
* **a fitted residual's autocovariance** (:mod:`._projection`): :func:`fitted_correlation`
  gives back what a least-squares fit's projection took from the errors' autocovariance (every
  lag reads low by about the long-run variance times tr(H D_k)/n: a third of it for 16 terms on
  3,000 rows), and finds Sokal's window on the corrected tau(M); with n_eff - p degrees of
  freedom (:class:`FittedCorrelation`), the polynomial family's and the SLS sandwich's.
* **sandwich covariance** (:mod:`._sandwich`): :func:`autocov_covariance`, the OLS sandwich with
  the residual's Toeplitz autocovariance up to Sokal's window, within segments or in row order,
  falling back to its Bartlett taper where the truncated one is not positive definite; the
  intervals of every family and of the balance. :func:`hac_covariance` (Newey-West, lags by
  :func:`hac_lags`) is the opt-in alternative.
* **AR(1) + white errors** (:mod:`._ar_white`): on a record only a few correlation times long
  (a free fall) a lag window holds too few lags and the fit has absorbed the errors' slow part;
  :func:`fit_ar_white` fits that covariance through the fit's projection instead
  (:class:`ARWhite`), for the friction stage.
* **inference on n_eff** (:mod:`._effective`): nested-model F-test and BIC
  (:class:`NestedTest`), Holm's correction (:func:`holm`) and profile-likelihood intervals
  (:func:`likelihood_interval`), for the loop; a block bootstrap's resamples
  (:func:`block_resamples`), for the loop's paired changes.
"""

from hmid.stats._ar_white import ARWhite, fit_ar_white
from hmid.stats._autocorrelation import (
    Segmented,
    acf_lags,
    autocorrelation,
    integrated_time,
    lag_count,
    masked_series,
    residual_correlation,
    residual_tau_int,
    sokal_window,
)
from hmid.stats._effective import NestedTest, block_resamples, holm, likelihood_interval
from hmid.stats._projection import FittedCorrelation, fitted_correlation, lag_traces
from hmid.stats._sandwich import autocov_covariance, hac_covariance, hac_lags

__all__ = [
    "ARWhite",
    "FittedCorrelation",
    "NestedTest",
    "Segmented",
    "acf_lags",
    "autocorrelation",
    "autocov_covariance",
    "block_resamples",
    "fit_ar_white",
    "fitted_correlation",
    "hac_covariance",
    "hac_lags",
    "holm",
    "integrated_time",
    "lag_count",
    "lag_traces",
    "likelihood_interval",
    "masked_series",
    "residual_correlation",
    "residual_tau_int",
    "sokal_window",
]
