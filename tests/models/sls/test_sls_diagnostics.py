"""Trace and corner plots of a sampler run, and the lag-1 residual correlation test."""

from __future__ import annotations

import numpy as np
import pytest

from hmid.errors import ConfigError, SignalError
from hmid.models.sls.diagnostics import (
    corner_plot,
    lag1_autocorrelation,
    residuals_correlated,
    trace_plot,
)
from hmid.models.sls.sampler import SamplerConfig, run_sampler


@pytest.fixture(scope="module")
def result():
    def gaussian(theta):
        return -0.5 * np.sum((theta / np.array([1.0, 0.1])) ** 2, axis=1)

    config = SamplerConfig(n_walkers=8, max_steps=400, check_every=100, seed=2)
    return run_sampler(gaussian, np.array([0.5, 0.05]), config, names=["k", "c"])


def test_trace_plot_writes_one_panel_per_parameter(result, tmp_path):
    path = trace_plot(result, tmp_path / "trace.png")
    assert path.stat().st_size > 10_000 and path.read_bytes()[:4] == b"\x89PNG"
    assert trace_plot(result, tmp_path / "trace_k.svg", names=["k"]).read_text().startswith("<?xml")
    with pytest.raises(ConfigError, match="unknown parameter"):
        trace_plot(result, tmp_path / "bad.png", names=["zeta"])


def test_corner_plot_uses_the_thinned_draws(result, tmp_path):
    path = corner_plot(result, tmp_path / "corner.png", labels=["$k$", "$c$"], truths=[0, 0])
    assert path.stat().st_size > 10_000
    with pytest.raises(ConfigError, match="need 2 labels"):
        corner_plot(result, tmp_path / "bad.png", labels=["k"])


def test_corner_plot_of_a_tight_pair_says_nothing_on_the_console(result, tmp_path, caplog):
    """corner logs "Too few points to create valid contours" for a degenerate pair; the
    figure still shows it, so the run's console stays clean (and other records pass)."""
    import dataclasses
    import logging

    n = len(result.chain)
    chain = np.column_stack([np.full(n, 1.0), np.full(n, 2.0)])
    chain[::7, 0] += 1e-9  # nearly every draw in one bin: no distinct contour levels
    chain[::11, 1] += 1e-9
    tight = dataclasses.replace(result, chain=chain)
    with caplog.at_level(logging.WARNING):
        corner_plot(tight, tmp_path / "tight.png")
        logging.getLogger().warning("still heard")
    messages = [r.getMessage() for r in caplog.records]
    assert "still heard" in messages
    assert not any("contours" in m for m in messages)


def test_plots_leave_pyplot_alone(result, tmp_path):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    trace_plot(result, tmp_path / "t.png")
    corner_plot(result, tmp_path / "c.png")
    assert plt.get_fignums() == before


def _ar1(phi: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal(n)
    out = np.empty(n)
    out[0] = noise[0]
    for t in range(1, n):
        out[t] = phi * out[t - 1] + noise[t]
    return out


def test_lag1_matches_statsmodels_ljung_box():
    from statsmodels.stats.diagnostic import acorr_ljungbox
    from statsmodels.tsa.stattools import acf

    residual = _ar1(0.2, 300, seed=4) + 3.0
    rho, p_value = lag1_autocorrelation(residual)
    table = acorr_ljungbox(residual, lags=[1])
    assert rho == pytest.approx(acf(residual, nlags=1)[1], rel=1e-12)
    assert p_value == pytest.approx(float(table["lb_pvalue"].iloc[0]), rel=1e-9)


def test_residuals_correlated_detects_ar1_not_white_noise():
    rho, p_value = lag1_autocorrelation(_ar1(0.5, 2000, seed=1))
    assert rho == pytest.approx(0.5, abs=0.05) and p_value < 1e-20
    assert residuals_correlated(_ar1(0.5, 2000, seed=1))
    white = np.random.default_rng(3).standard_normal(2000)
    assert not residuals_correlated(white, alpha=0.01)
    # with many samples a tiny correlation is "significant"; min_abs_rho ignores it
    weak = _ar1(0.03, 200_000, seed=5)
    assert residuals_correlated(weak) and not residuals_correlated(weak, min_abs_rho=0.1)


def test_lag1_rejects_bad_residuals():
    with pytest.raises(SignalError, match="row 2: non-finite"):
        lag1_autocorrelation(np.array([1.0, 2.0, np.nan, 4.0]))
    with pytest.raises(SignalError, match="constant"):
        lag1_autocorrelation(np.ones(10))
    with pytest.raises(SignalError, match="1-D residual"):
        lag1_autocorrelation(np.ones((3, 3)))
    with pytest.raises(ConfigError, match="alpha"):
        residuals_correlated(np.arange(10.0), alpha=1.5)
