"""Autocorrelation over gaps, integrated time, nested tests and intervals (hmid.stats)."""

import numpy as np
import pandas as pd
from statsmodels.tsa.stattools import acf

from hmid.balance import Signals
from hmid.stats import (
    NestedTest,
    autocorrelation,
    holm,
    integrated_time,
    likelihood_interval,
    masked_series,
)


def _data(n: int, rows: np.ndarray, segments: int = 2) -> Signals:
    frame = pd.DataFrame(
        {
            "log": "a",
            "segment": np.repeat(np.arange(segments), n // segments),
            "t": np.arange(n) * 1e-3,
            "target": 0.0,
            "train": rows,
        }
    )
    return Signals.from_frame(frame, {"target": "N"})


def test_acf_equals_statsmodels_pairwise_over_gaps():
    rng = np.random.default_rng(1)
    n = 4000
    x = np.convolve(rng.normal(size=n + 20), np.ones(20) / 20, "valid")[:n]
    rows = rng.random(n) > 0.2
    data = _data(n, rows)
    ours = autocorrelation(x, rows, data, 30)
    series = masked_series(x - x[rows].mean(), rows, data, 30)
    reference = acf(series, nlags=30, missing="conservative", adjusted=True, fft=False)
    np.testing.assert_allclose(ours, reference, atol=1e-12)


def test_integrated_time_of_an_ar1_process():
    rng = np.random.default_rng(2)
    phi, n = 0.9, 200_000
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0]
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    rows = np.ones(n, dtype=bool)
    tau = integrated_time(autocorrelation(x, rows, _data(n, rows, 1), 400))
    assert abs(tau / ((1 + phi) / (1 - phi)) - 1) < 0.1


def test_a_window_that_never_closes_gives_a_lower_bound_not_zero():
    assert integrated_time(np.ones(50)) == 99.0


def test_nested_f_test_is_calibrated_under_the_null():
    rng = np.random.default_rng(3)
    n, rejections = 400, 0
    X = np.column_stack([np.ones(n), np.linspace(0, 1, n)])
    extra = rng.normal(size=(n, 1))
    for _ in range(400):
        y = X @ [1.0, 2.0] + rng.normal(size=n)
        sse0 = np.sum((y - X @ np.linalg.lstsq(X, y, rcond=None)[0]) ** 2)
        X1 = np.hstack([X, extra])
        sse1 = np.sum((y - X1 @ np.linalg.lstsq(X1, y, rcond=None)[0]) ** 2)
        rejections += NestedTest.of(sse0, sse1, 1, 3, n).p_value < 0.05
    assert 0.03 < rejections / 400 < 0.075


def test_a_candidate_that_adds_nothing_is_never_significant():
    test = NestedTest.of(10.0, 10.0, 0, 3, 100)
    assert (test.f, test.p_value, test.q) == (0.0, 1.0, 0)


def test_a_likelihood_interval_holds_the_minimum_and_widens_with_less_data():
    grid = np.linspace(0, 1, 21)
    sse = 100 * (1 + (grid - 0.5) ** 2)
    best = (0.5, 100.0)
    narrow = likelihood_interval(grid, sse, 1000, 0.95, best)
    wide = likelihood_interval(grid, sse, 50, 0.95, best)
    assert narrow[0] <= 0.5 <= narrow[1]
    assert wide[0] <= narrow[0] and wide[1] >= narrow[1] and wide != narrow


def test_holm_matches_statsmodels():
    from statsmodels.stats.multitest import multipletests

    p = np.random.default_rng(7).uniform(0, 0.05, 9) ** 2
    np.testing.assert_allclose(holm(list(p)), multipletests(p, method="holm")[1], rtol=1e-12)
    assert holm([]).size == 0


def _inflated_ols_widths(X: np.ndarray, y: np.ndarray, rows, signals) -> np.ndarray:
    """Half-widths of the method before: OLS errors inflated by sqrt(tau_int)."""
    import statsmodels.api as sm

    from hmid.stats import residual_tau_int

    fit = sm.OLS(y[rows], X[rows]).fit()
    residual = np.zeros(len(y))
    residual[rows] = fit.resid
    tau = residual_tau_int(residual, signals, rows)
    return np.asarray(fit.bse) * np.sqrt(tau) * 1.96


def test_coefficient_intervals_cover_the_truth_under_strongly_correlated_noise():
    # AR(1) phi 0.97 (tau_int 66 rows) on regressors faster than the noise: the autocovariance
    # sandwich covers at its level; the n/tau_int inflation was 1.25x too wide here
    from scipy.signal import lfilter

    from hmid.balance import inference
    from hmid.balance.columns import Columns

    n, phi = 8000, 0.97
    t = np.arange(n) * 1e-3
    X = np.column_stack([np.ones(n), np.sin(2 * np.pi * 3 * t), np.sign(np.sin(2 * np.pi * 7 * t))])
    truth = np.array([0.2, 1.0, 0.5])
    rows = np.ones(n, bool)
    rows[[0, n // 2 - 1, n // 2, n - 1]] = False
    signals = _data(n, rows)
    columns = Columns(("a", "b", "c"), ("N", "N", "N"), X)
    hits, ratio = [], []
    for seed in range(60):
        rng = np.random.default_rng(seed)
        e = lfilter([1.0], [1.0, -phi], rng.normal(0, 0.02 * np.sqrt(1 - phi**2), n + 700))[700:]
        y = X @ truth + e
        table = inference(columns, y, rows, signals, 0.95)
        hits.append((table["lower"] <= truth) & (truth <= table["upper"]))
        half = (table["upper"] - table["lower"]).to_numpy() / 2
        ratio.append(half / _inflated_ols_widths(X, y, rows, signals))
    coverage = float(np.mean(hits))
    assert 0.9 <= coverage <= 0.99, coverage
    assert np.median(ratio) < 0.92, np.median(ratio)  # narrower than the n/tau_int inflation


def test_a_likelihood_interval_is_refined_at_its_crossings_and_holds_its_estimate():
    grid = np.round(np.arange(0, 0.1001, 0.0025), 4)
    n_eff, truth, width = 2000.0, 0.0247, 0.0004  # a minimum between grid points, narrow
    sse = 100 * (1 + ((grid - truth) / width) ** 2 / n_eff)
    low, high = likelihood_interval(grid, sse, n_eff, 0.95, (truth, 100.0))
    assert low < truth < high  # at grid resolution this was [0.025, 0.025]
    half = 1.96 * width  # the exact crossing of this quadratic profile
    assert truth - 1.05 * half < low < truth and truth < high < truth + 1.05 * half
    # a log grid, interpolated in the logarithm; the edge of the grid ends an open interval
    lags = np.geomspace(0.001, 0.2, 24)
    flat = np.full(24, 50.0)
    assert likelihood_interval(lags, flat, 100, 0.95, (0.01, 50.0), log=True) == (0.001, 0.2)
    # values never evaluated (inf) are left out
    sse = np.where(np.abs(grid - truth) < 0.01, sse, np.inf)
    low2, high2 = likelihood_interval(grid, sse, n_eff, 0.95, (truth, 100.0))
    assert (low2, high2) == (low, high)
