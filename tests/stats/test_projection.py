"""A fitted residual's autocovariance, given back what the fit's projection took: the lag
traces are the dense tr(H D_k), and on a short log with many slow terms the corrected
correlation time is the errors' own where the residual's reads it short."""

import numpy as np
from scipy import fft
from scipy.signal import lfilter

from hmid.models._lstsq import RowBlocks
from hmid.stats import fitted_correlation, lag_traces, residual_correlation


def _slow_design(n: int, p: int) -> np.ndarray:
    """A constant and p - 1 slow waves over n rows (a rig log's regressors against a 1 kHz
    residual: each changes over hundreds of rows)."""
    t = np.linspace(0.0, 1.0, n)
    waves = [np.sin(2 * np.pi * (0.5 + k) * t + k) for k in range(p - 1)]
    return np.column_stack([np.ones(n), *waves])


def _ar1(phi: float, n: int, rng: np.random.Generator) -> np.ndarray:
    burn = int(20 / (1 - phi))
    e = lfilter([1.0], [1.0, -phi], rng.normal(0.0, np.sqrt(1 - phi**2), n + burn))
    return e[burn:]


def test_the_lag_traces_are_the_hat_matrix_shifted_by_k_rows():
    rng = np.random.default_rng(4)
    X = np.column_stack([np.ones(300), rng.normal(size=300), np.linspace(-1, 1, 300)])
    bread = np.linalg.inv(X.T @ X)
    hat = X @ bread @ X.T
    expected = [np.trace(hat, offset=k) for k in range(25)]  # sum_t H[t, t + k]
    np.testing.assert_allclose(lag_traces(X, bread, 24), expected, rtol=1e-10, atol=1e-12)
    for block in (7, 64, 299):  # by blocks of rows, each reaching k rows past its end
        np.testing.assert_allclose(lag_traces(X, bread, 24, block), expected, atol=1e-12)
    size = fft.next_fast_len(300 + 24, real=True)  # from the design's own transform
    whole = (size, fft.rfft(X, size, axis=0))
    np.testing.assert_allclose(lag_traces(X, bread, 24, spectrum=whole), expected, atol=1e-12)
    blocks = RowBlocks(300, [lambda rows, j=j: X[rows, j] for j in range(3)])
    np.testing.assert_allclose(lag_traces(blocks, bread, 24, 50), expected, atol=1e-12)


def test_on_a_short_log_with_many_terms_the_corrected_tau_int_is_the_errors_own():
    # AR(1) phi 0.9 (tau_int 19) on 3,000 rows with 16 slow terms: the fit takes about
    # 16 x 2M / n of the window's long-run variance, and the residual's own tau_int reads short
    # (median about 14); corrected, its median lies within 15 % of 19 (40 replications)
    n, p, tau = 3000, 16, 19.0
    X = _slow_design(n, p)
    bread = np.linalg.inv(X.T @ X)
    raw, corrected = [], []
    for rep in range(40):
        rng = np.random.default_rng(np.random.SeedSequence(30, spawn_key=(rep,)))
        e = _ar1(0.9, n, rng)
        resid = e - X @ (bread @ (X.T @ e))
        fitted = fitted_correlation(resid, X, bread)
        raw.append(residual_correlation(resid)[2])
        corrected.append(fitted.tau_int)
        assert fitted.gamma[0] > np.mean(resid**2)  # every lag raised, lag 0 too
    assert np.median(raw) < 0.85 * tau, np.median(raw)
    assert abs(np.median(corrected) / tau - 1) < 0.15, np.median(corrected)


def test_a_white_residual_stays_white_and_its_n_eff_is_its_rows():
    rng = np.random.default_rng(9)
    X = _slow_design(4000, 16)
    bread = np.linalg.inv(X.T @ X)
    e = rng.normal(size=4000)
    fitted = fitted_correlation(e - X @ (bread @ (X.T @ e)), X, bread)
    assert fitted.tau_int < 1.5 and fitted.window is not None and fitted.window < 10
    assert fitted.n_eff > 4000 / 1.5 and fitted.dof(16) == fitted.n_eff - 16


def test_a_window_the_projection_would_swallow_is_left_open():
    # 1,000 rows, 40 slow terms, AR(1) phi 0.97 (tau_int 66): a window of 5 tau_int would hold
    # more than the rows per term; no window is read, and tau_int is only a lower bound
    X = _slow_design(1000, 40)
    bread = np.linalg.inv(X.T @ X)
    e = _ar1(0.97, 1000, np.random.default_rng(2))
    fitted = fitted_correlation(e - X @ (bread @ (X.T @ e)), X, bread)
    assert fitted.window is None
