"""The sandwich covariance over log segments is the dense one with S Toeplitz within segments
only, and a truncated autocovariance that is not positive definite falls back to its taper."""

import numpy as np
import pandas as pd
from scipy.linalg import block_diag, toeplitz

from hmid.balance import Signals
from hmid.stats import autocov_covariance, sokal_window


def _signals(lengths: list[int], train: np.ndarray) -> Signals:
    n = sum(lengths)
    frame = pd.DataFrame(
        {
            "log": "a",
            "segment": np.repeat(np.arange(len(lengths)), lengths),
            "t": np.arange(n) * 1e-3,
            "target": 0.0,
            "train": train,
        }
    )
    return Signals.from_frame(frame, {"target": "N"})


def test_the_segment_sandwich_pairs_no_rows_of_two_segments_or_left_out_rows():
    rng = np.random.default_rng(5)
    lengths = [120, 80, 150]
    n = sum(lengths)
    rows = rng.random(n) > 0.25
    signals = _signals(lengths, rows)
    X = np.column_stack([np.ones(n), rng.normal(size=n), np.linspace(-1, 1, n)])
    gamma = 0.8 ** np.arange(9)
    bread = np.linalg.inv(X[rows].T @ X[rows])
    sigma = block_diag(*[toeplitz(np.r_[gamma, np.zeros(m - gamma.size)]) for m in lengths])
    sigma = sigma * np.outer(rows, rows)  # left-out rows pair with nothing
    used = int(rows.sum())
    expected = bread @ X.T @ sigma @ X @ bread * used / (used - 3)
    found = autocov_covariance(X, gamma, bread, rows=rows, segmented=signals)
    np.testing.assert_allclose(found, expected, rtol=1e-10)


def test_one_segment_of_every_row_is_the_row_order_sandwich():
    rng = np.random.default_rng(6)
    n = 400
    X = np.column_stack([np.ones(n), rng.normal(size=n)])
    gamma = 0.7 ** np.arange(15)
    rows = np.ones(n, dtype=bool)
    bread = np.linalg.inv(X.T @ X)
    segment = autocov_covariance(X, gamma, bread, rows=rows, segmented=_signals([n], rows))
    np.testing.assert_allclose(segment, autocov_covariance(X, gamma, bread), rtol=1e-10)


def test_a_truncated_autocovariance_without_positive_variances_falls_back_to_its_taper():
    n = 300
    X = np.column_stack([np.ones(n), np.cos(np.arange(n) * np.pi)])  # alternating: lag 1 counts
    gamma = np.array([1.0, 0.7, 0.0])  # not positive definite: alternating rows see 1 - 1.4
    plain = np.linalg.inv(X.T @ X)
    meat = X.T @ toeplitz(np.r_[gamma, np.zeros(n - 3)]) @ X
    assert np.diag(plain @ meat @ plain)[1] < 0
    tapered = gamma * (1 - np.arange(3) / 3)
    expected = plain @ X.T @ toeplitz(np.r_[tapered, np.zeros(n - 3)]) @ X @ plain * n / (n - 2)
    found = autocov_covariance(X, gamma)
    assert np.all(np.diag(found) > 0)
    np.testing.assert_allclose(found, expected, rtol=1e-10, atol=1e-15)


def test_sokal_window_closes_at_the_first_lag_past_c_tau_and_says_when_it_never_does():
    acf = 0.5 ** np.arange(40)
    window, tau = sokal_window(acf)
    taus = 2 * np.cumsum(acf) - 1
    assert window == int(np.flatnonzero(np.arange(40) >= 5 * taus)[0]) and tau == taus[window]
    assert sokal_window(np.ones(50)) == (None, 99.0)
