"""Residual diagnostics: noise shows no structure, a dependence on a signal does."""

import numpy as np
from _loop_data import make_data

from hmid.loop.diagnostics import diagnose, pattern_scan


def test_white_noise_has_no_structure_and_passes_ljung_box():
    data, _ = make_data(None)
    noise = np.random.default_rng(5).normal(0, 0.1, len(data))
    d = diagnose(noise, data, max_lag_s=0.2, stride_s=0.02)
    assert d.strongest[1] < 0.01
    assert d.ljung_box_p > 0.001
    assert np.all(np.abs(d.acf[5:]) < 3 * d.acf_bound)
    assert abs(d.tau_int - 1) < 0.5


def test_a_multiplicative_dependence_is_seen_where_linear_correlation_is_not():
    data, _ = make_data(None)
    v = data["v"]
    residual = np.sign(v) * np.cos(2 * np.pi * data["x"] / 0.01)  # ~uncorrelated with x and v
    rows = data.train
    assert abs(np.corrcoef(residual[rows], data["x"][rows])[0, 1]) < 0.2
    eta = pattern_scan(residual, rows, data)["eta2"]
    assert eta["x"] > 0.5


def test_a_slow_drift_is_attributed_to_time():
    data, _ = make_data(None)
    residual = data["t"] / data["t"].max() + np.random.default_rng(6).normal(0, 0.1, len(data))
    eta = pattern_scan(residual, data.train, data)["eta2"]
    assert eta.idxmax() == "t" and eta["t"] > 0.5
