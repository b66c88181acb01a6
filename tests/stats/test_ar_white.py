"""The AR(1)-plus-white covariance of least squares on a short record: its expectations
through the fit's projection equal the dense ones, and on a 0.18 s record whose errors stay
correlated for 19 samples its intervals cover where the residual's own autocovariance does not."""

import numpy as np
import pytest
from scipy import stats

from hmid.stats import autocov_covariance, fit_ar_white, residual_correlation
from hmid.stats._ar_white import _expected

N = 180  # samples of a free fall's sliding segment at 1 kHz


def quadratic(n: int = N) -> np.ndarray:
    tau = np.linspace(-0.09, 0.09, n)
    design = np.column_stack([np.ones(n), tau, 0.5 * tau**2])
    return design / np.sqrt(np.mean(design**2, axis=0))


@pytest.mark.parametrize("phi", [None, 0.3, 0.9, 0.99])
def test_the_expected_lag_sums_are_those_of_the_dense_matrices(phi):
    q, _ = np.linalg.qr(quadratic(40))
    n = len(q)
    lag = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    covariance = np.eye(n) if phi is None else phi**lag
    projection = np.eye(n) - q @ q.T
    expected = projection @ covariance @ projection
    dense = [np.trace(expected, offset=k) for k in range(3)]
    np.testing.assert_allclose(_expected(q, phi), dense, rtol=1e-10, atol=1e-10)


def errors(rng, phi: float, n: int = N) -> np.ndarray:
    """AR(1) noise (stationary start) plus white noise of a third of its sd."""
    e = np.empty(n)
    e[0] = rng.normal() / np.sqrt(1 - phi**2)
    for k in range(1, n):
        e[k] = phi * e[k - 1] + rng.normal()
    return e * np.sqrt(1 - phi**2) + rng.normal(0.0, 1 / 3, n)


def test_short_correlated_records_are_covered_where_the_lag_window_is_not():
    rng = np.random.default_rng(7)
    design = quadratic()
    bread = np.linalg.pinv(design.T @ design)
    hits = {"AR(1) + white": [], "lag window": []}
    phis, taus = [], []
    for _ in range(300):
        resid_all = errors(rng, 0.9)
        coef = bread @ design.T @ resid_all  # truth 0: the curvature's estimate is its error
        resid = resid_all - design @ coef
        model = fit_ar_white([(design, resid)])
        cov, phi, tau = model.covariance(design), model.phi, model.tau_int
        phis.append(phi)
        taus.append(tau)
        dof = N * (1 - phi) / (1 + phi)
        hits["AR(1) + white"].append(abs(coef[2]) <= stats.t.ppf(0.975, dof) * np.sqrt(cov[2, 2]))
        gamma, window, _ = residual_correlation(resid)
        lags = window if window is not None else gamma.size - 1
        window_cov = autocov_covariance(design, gamma[: lags + 1])
        z = stats.t.ppf(0.975, N / (2 * lags + 1))
        hits["lag window"].append(abs(coef[2]) <= z * np.sqrt(window_cov[2, 2]))
    coverage = {k: np.mean(v) for k, v in hits.items()}
    # 300 records, s.e. of a coverage near 0.95 is 0.013: the band 0.92-0.99 is issue 15's
    # (nominal +- 3 points, widened above by one s.e.); measured 0.93 with this seed
    assert 0.92 <= coverage["AR(1) + white"] <= 0.99, coverage
    assert coverage["lag window"] < 0.9, coverage  # what the lag window alone gave
    assert 0.8 < np.median(phis) < 0.95  # phi recovered through the projection
    # the errors' correlation time: 1 + 2 (0.9 of the variance) 0.9 / 0.1 = 17.2 samples
    assert 10 < np.median(taus) < 25, np.median(taus)


def test_a_white_residual_is_left_to_the_other_covariances():
    """A white residual's lag sums are noise, and a phi taken from them can lie near 1: the
    model is used only past white noise's bound on the lag-1 autocorrelation."""
    rng = np.random.default_rng(3)
    design = quadratic()
    bread = np.linalg.pinv(design.T @ design)
    used = 0
    for _ in range(200):
        resid = rng.normal(size=N)
        resid -= design @ (bread @ design.T @ resid)
        used += fit_ar_white([(design, resid)]) is not None
    assert used <= 10  # 2.5 % expected from the one-sided bound


def test_records_of_one_sensor_share_one_model_whose_intervals_cover_where_each_alone_does_not():
    """Three 0.18 s records under AR(1) phi 0.97 (correlation time ~66 samples, under three in
    a record): one record's own model reads phi too low as often as not, and its intervals fall
    short; the model fitted on all three at once (the falls of one sensor) covers. Each
    interval is t on its own record's n (1 - phi) / (1 + phi) degrees of freedom."""
    rng = np.random.default_rng(11)
    design = quadratic()
    bread = np.linalg.pinv(design.T @ design)
    hits = {"own": [], "shared": []}
    shared_phi = []
    for _ in range(300):
        records, errors_of_curvature = [], []
        for _ in range(3):
            e = errors(rng, 0.97)
            coef = bread @ design.T @ e  # truth 0: the curvature's estimate is its error
            records.append((design, e - design @ coef))
            errors_of_curvature.append(coef[2])
        shared = fit_ar_white(records)
        assert shared is not None and shared.n_rows == 3 * N
        shared_phi.append(shared.phi)
        for k, error in enumerate(errors_of_curvature):
            for name, model in (("own", fit_ar_white(records[k : k + 1])), ("shared", shared)):
                if model is None:  # read as white: no interval from this model
                    hits[name].append(False)
                    continue
                half = stats.t.ppf(0.975, N * (1 - model.phi) / (1 + model.phi))
                hits[name].append(abs(error) <= half * np.sqrt(model.covariance(design)[2, 2]))
    coverage = {k: float(np.mean(v)) for k, v in hits.items()}
    # 900 intervals (s.e. ~0.008 near 0.95); measured with this seed: own 0.89, shared 0.94
    assert 0.92 <= coverage["shared"] <= 0.98, coverage
    assert coverage["own"] < coverage["shared"] - 0.03, coverage
    assert 0.93 < np.median(shared_phi) < 0.99
