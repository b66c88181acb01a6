"""SLS model: exact arm recursion, agreement with the rig simulator, likelihoods, prior, data."""

from __future__ import annotations

import math

import jax
import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp
from scipy.stats import norm

from hmid.errors import ConfigError, SignalError
from hmid.models.sls._data import sls_data
from hmid.models.sls._space import SLSSpace
from hmid.models.sls.model import SLSModel
from hmid.signal.maxwell import SCANS, unit_response
from hmid.simulate.params import RigParams
from hmid.simulate.profiles import Chirp
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle


def _segment(rng, n, use=None, t0=0.0):
    """A log with uneven steps (0.5-2 ms) and a smooth random elongation."""
    t = t0 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.5e-3, 2e-3, n - 1))])
    x = 0.006 + 0.003 * np.sin(2 * np.pi * 3.1 * t) + 0.001 * np.sin(2 * np.pi * 17 * t + 1)
    P = 1.4e5 + 8e4 * np.sin(2 * np.pi * 2.3 * t)
    use = np.ones(n, bool) if use is None else use
    return pd.DataFrame({"t": t, "x": x, "P": P, "F": np.zeros(n), "use": use})


def _ode_arms(frame, k2, tau):
    """q = sum of arms by solve_ivp (rtol 1e-12), one interval at a time at constant velocity."""
    t, x = frame["t"].to_numpy(), frame["x"].to_numpy()
    k2, tau = np.asarray(k2), np.asarray(tau)
    q = np.zeros((len(t), len(tau)))
    for k in range(len(t) - 1):
        v = (x[k + 1] - x[k]) / (t[k + 1] - t[k])
        sol = solve_ivp(lambda _, y, v=v: -y / tau + k2 * v, (t[k], t[k + 1]), q[k],
                        method="DOP853", rtol=1e-12, atol=1e-15)  # fmt: skip
        q[k + 1] = sol.y[:, -1]
    return q.sum(axis=1)


_unit_response = jax.jit(unit_response, static_argnames="scan")


def _recursion_q(frames, k2, tau, scan):
    data = sls_data(frames)
    with jax.enable_x64(True):
        g = np.asarray(_unit_response(data.t, data.x, data.start, np.asarray(tau), scan=scan))
    return g @ np.asarray(k2)


_ARMS = {"one arm": ([1500.0], [0.2]), "two arms": ([1500.0, 700.0], [0.004, 0.8])}


@pytest.fixture(scope="module")
def ode_reference():
    frame = _segment(np.random.default_rng(0), 200)
    return frame, {name: _ode_arms(frame, *arms) for name, arms in _ARMS.items()}


@pytest.mark.parametrize("scan", sorted(SCANS))
@pytest.mark.parametrize("arms", sorted(_ARMS))
def test_recursion_is_exact_on_uneven_steps(ode_reference, arms, scan):
    frame, expected = ode_reference
    got = _recursion_q([frame], *_ARMS[arms], scan)
    assert np.max(np.abs(got - expected[arms])) <= 1e-10 * np.max(np.abs(expected[arms]))


def test_recursion_restarts_at_each_log():
    rng = np.random.default_rng(1)
    a, b = _segment(rng, 100), _segment(rng, 80)  # b's clock restarts at 0
    k2, tau = [1500.0, 700.0], [0.01, 0.3]
    got = _recursion_q([a, b], k2, tau, "sequential")
    expected = np.concatenate([_ode_arms(a, k2, tau), _ode_arms(b, k2, tau)])
    assert got[100] == 0.0
    assert np.max(np.abs(got - expected)) <= 1e-10 * np.max(np.abs(expected))
    for scan in SCANS:
        np.testing.assert_allclose(_recursion_q([a, b], k2, tau, scan), got, rtol=1e-13, atol=1e-14)


def test_predict_reproduces_the_simulator():
    """The simulator moves x linearly over substeps h = 1/(rate S) and advances q exactly for
    that path; it logs F_m at the logged state (time t_k). Our recursion takes x linear over the
    whole sample interval D = 1/rate, so one error remains, derived and checked here:

    * piecewise-linear path: with e = x - x_lin (zero at the samples),
      q(t_k) - q_lin(t_k) = -(k2/tau) int exp(-(t_k-s)/tau) e(s) ds, so
      |dq| <= k2 max|e| <= k2 D²/8 max|a|.

    (The simulator once logged F_m of the last substep's start, h earlier than x: a lag the loop
    found in clean data as negative damping.)
    """
    rig, rate, substeps = RigParams(), 1000.0, 50
    t = np.arange(1, 3001) / rate
    tr = integrate(HydroMuscle(rig), {"P_cmd": Chirp().command(t, None)}, rate, substeps=substeps)
    m = rig.muscle
    frame = pd.DataFrame({"t": tr.t, "x": tr.x, "P": tr.P, "F": tr.F_m, "use": True})
    truth = {"A_eff": m.A_eff, "F0": m.F0, "k1": m.k1, "k3": m.k3, "k2": m.k2, "tau": m.tau}
    pred = SLSModel(spring="cubic").predict(truth, sls_data([frame]))
    assert tr.q[0] == 0.0  # the log starts from rest, as the recursion assumes

    D = 1.0 / rate
    path_bound = m.k2 * D**2 / 8 * np.max(np.abs(tr.a))
    instant = m.A_eff * tr.P + m.F0 - m.k1 * tr.x - m.k3 * tr.x**3 - tr.q
    np.testing.assert_allclose(tr.F_m, instant, rtol=0, atol=1e-12)  # logged at its state
    assert np.max(np.abs(pred - tr.F_m)) <= path_bound
    assert path_bound < 0.01  # below the 0.01 N force resolution


def _small_problem(noise, seed=3):
    rng = np.random.default_rng(seed)
    use_a = rng.uniform(size=40) > 0.2
    use_b = np.ones(30, bool)
    use_b[:3] = False
    frames = [_segment(rng, 40, use_a), _segment(rng, 30, use_b)]
    for frame in frames:
        frame["F"] = 20 + rng.normal(0, 0.5, len(frame))
    model = SLSModel(spring="cubic", arms=2, noise=noise)
    theta = model.theta_from({"A_eff": 2e-4, "F0": 1.0, "k1": 3000.0, "k3": 2e6, "k2_1": 900.0,
                              "tau_1": 0.01, "k2_2": 400.0, "tau_2": 0.4, "sigma": 0.3,
                              "phi": 0.6})  # fmt: skip
    return model, sls_data(frames), theta


def test_iid_likelihood_equals_scipy():
    model, data, theta = _small_problem("iid")
    use = np.asarray(data.use)
    r = np.asarray(data.F) - model.predict(theta, data)
    expected = norm.logpdf(r[use], 0.0, 0.3).sum()
    assert float(model.log_likelihood(theta, data)) == pytest.approx(expected, rel=1e-12)


def test_ar1_likelihood_equals_scipy():
    model, data, theta = _small_problem("ar1")
    use, start = np.asarray(data.use), np.asarray(data.start)
    r = np.asarray(data.F) - model.predict(theta, data)
    sigma, phi, expected = 0.3, 0.6, 0.0
    for k in np.flatnonzero(use):
        if k > 0 and use[k - 1] and not start[k]:
            expected += norm.logpdf(r[k], phi * r[k - 1], sigma)
        else:
            expected += norm.logpdf(r[k], 0.0, sigma / math.sqrt(1 - phi**2))
    assert float(model.log_likelihood(theta, data)) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("noise", ["iid", "ar1"])
def test_walkers_equal_row_by_row_and_nan_is_minus_inf(noise):
    model, data, theta = _small_problem(noise)
    rng = np.random.default_rng(4)
    batch = theta + 0.05 * rng.normal(size=(5, theta.size))
    batch[:, 5] = theta[5]  # keep tau_1 < tau_2
    batch[:, 7] = theta[7]
    together = np.asarray(model.log_likelihood(batch, data))
    alone = [float(model.log_likelihood(row, data)) for row in batch]
    np.testing.assert_allclose(together, alone, rtol=1e-13)
    np.testing.assert_allclose(
        np.asarray(model.log_prob(batch, data)),
        together + np.asarray(model.log_prior(batch)), rtol=1e-13,
    )  # fmt: skip
    batch[1, 0] = np.nan
    batch[2, 5] = 800.0  # tau = exp(800) overflows
    lp = np.asarray(model.log_prob(batch, data))
    assert lp[1] == -np.inf and lp[2] == -np.inf
    assert np.isfinite(lp[[0, 3, 4]]).all()
    assert float(model.log_prob(batch[1], data)) == -np.inf
    as_numpy = model.log_prob_fn(data)(batch)  # the form emcee calls
    assert isinstance(as_numpy, np.ndarray) and as_numpy.dtype == np.float64
    np.testing.assert_array_equal(as_numpy, lp)


def test_new_data_of_the_same_length_reuses_the_compiled_likelihood():
    from hmid.models.sls import model as model_module

    model, data, theta = _small_problem("ar1")
    first = float(model.log_likelihood(theta, data))
    compiled = model_module._log_likelihood._cache_size()
    _, other, _ = _small_problem("ar1", seed=4)
    second = float(model.log_likelihood(theta, other))
    assert model_module._log_likelihood._cache_size() == compiled
    assert first != second


def test_space_names_units_transforms_and_prior():
    space = SLSSpace(spring="cubic", arms=2, noise="ar1")
    assert space.names[:4] == ("log_A_eff", "F0", "log_k1", "log_k3")
    assert space.names[-2:] == ("log_sigma", "atanh_phi")
    assert dict(zip(space.physical_names, space.units, strict=True))["tau_2"] == "s"
    assert dict(zip(space.physical_names, space.units, strict=True))["k3"] == "N/m³"
    assert SLSSpace(spring="linear").physical_names == ("A_eff", "F0", "k1", "k2", "tau", "sigma")
    theta = space.prior_centre()
    back = space.from_physical(space.to_physical(theta))
    np.testing.assert_allclose(back, theta, atol=1e-12)
    assert np.isfinite(float(space.log_prior(theta)))
    swapped = theta.copy()
    swapped[[5, 7]] = swapped[[7, 5]]  # tau_1 > tau_2: outside the ordered prior
    outside = theta.copy()
    outside[-1] = math.atanh(0.995)
    assert float(space.log_prior(swapped)) == -np.inf
    assert float(space.log_prior(outside)) == -np.inf
    # the one-arm prior integrates to 1 along log_tau (a proper density in theta)
    one = SLSSpace(arms=1)
    grid = np.linspace(-25, 20, 1001)
    points = np.repeat(one.prior_centre()[None], grid.size, axis=0)
    points[:, one.index("tau")] = grid
    marginal = np.exp(np.asarray(one.log_prior(points)) - float(one.log_prior(one.prior_centre())))
    assert np.trapezoid(marginal, grid) == pytest.approx(math.sqrt(2 * math.pi) * 3.0, rel=1e-6)


@pytest.mark.parametrize(
    "config", [{"spring": "quintic"}, {"arms": 0}, {"arms": 1.5}, {"noise": "ar2"}]
)
def test_bad_configuration_is_a_config_error(config):
    with pytest.raises(ConfigError, match="SLS"):
        SLSModel(**config)


def test_data_validation():
    rng = np.random.default_rng(5)
    frame = _segment(rng, 20)
    bad = frame.copy()
    bad.loc[7, "x"] = np.nan
    with pytest.raises(SignalError, match=r"segment 1: column 'x' row 7"):
        sls_data([frame, bad])
    backwards = frame.copy()
    backwards.loc[4, "t"] = backwards.loc[3, "t"]
    with pytest.raises(SignalError, match=r"column 't' row 4"):
        sls_data([backwards])
    unused_nan = frame.copy()
    unused_nan.loc[2, ["F", "use"]] = [np.nan, False]
    data = sls_data([unused_nan.astype({"use": bool})])
    assert float(data.F[2]) == 0.0 and data.n == 20
    assert np.asarray(data.start).tolist() == [True] + [False] * 19


@pytest.mark.parametrize("chunk", [7, 37])
@pytest.mark.parametrize("noise", ["iid", "ar1"])
def test_chunked_likelihood_equals_the_whole_array_scan(noise, chunk, monkeypatch):
    """Chunks that split a log mid-way (and a log boundary inside a chunk) carry the arm state
    and the AR(1) residual across: the same numbers as an unchunked scan."""
    from hmid.models.sls import likelihood

    model, data, theta = _small_problem(noise)
    batch = np.stack([theta, theta + 0.01])
    with jax.enable_x64(True):  # the pure functions, not the jitted ones: CHUNK is read each call
        whole = likelihood.log_likelihood(model.space, batch, data, "associative")
        whole_force = likelihood.force(model.space, batch, data, "associative")
        monkeypatch.setattr(likelihood, "CHUNK", chunk)
        chunked = likelihood.log_likelihood(model.space, batch, data, "sequential")
        chunked_force = likelihood.force(model.space, batch, data, "sequential")
    np.testing.assert_allclose(np.asarray(chunked), np.asarray(whole), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(chunked_force), np.asarray(whole_force), rtol=1e-12)


def test_the_cubic_spring_reads_the_data_s_cube_where_one_is_given():
    """Where x and F are smoothed, x3 carries the smoothed cube of the unsmoothed x (the cube of
    a smoothed x is biased); without it the cube of x is used, as for unsmoothed data."""
    t = np.arange(1, 2001) / 1000.0
    x = 0.01 + 0.005 * np.sin(2 * np.pi * t)
    frame = pd.DataFrame({"t": t, "x": x, "P": 2e5, "F": 0.0, "use": True})
    theta = {"A_eff": 2e-4, "F0": 0.0, "k1": 3e3, "k3": 2e6, "k2": 1e3, "tau": 0.2}
    model = SLSModel(spring="cubic")
    plain = model.predict(theta, sls_data([frame]))
    shifted = model.predict(theta, sls_data([frame.assign(x3=x**3 + 1e-8)]))
    np.testing.assert_allclose(plain - shifted, 2e6 * 1e-8, rtol=1e-9)
