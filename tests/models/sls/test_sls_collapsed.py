"""The exact (collapsed) SLS posterior against known truth and against emcee on the same target."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hmid.errors import ConfigError
from hmid.models.sls import SamplerConfig, SLSModel, SLSSpace, initial_fit, run_sampler, sls_data
from hmid.models.sls.collapsed import exact_posterior
from hmid.simulate.params import RigParams
from hmid.simulate.profiles import Chirp
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle

TRUTH = {"A_eff": 2.1e-4, "F0": 0.3, "k1": 3100.0, "k3": 1.9e6, "k2": 1400.0, "tau": 0.18}


def _data(seed: int, n: int, noise: str = "iid", sigma: float = 0.02, phi: float = 0.8):
    rng = np.random.default_rng(seed)
    t = np.arange(1, n + 1) / 1000.0
    traj = integrate(HydroMuscle(RigParams()), {"P_cmd": Chirp().command(t - t[0], rng)}, 1000.0)
    frame = pd.DataFrame({"t": t, "x": traj.x, "P": traj.P, "F": 0.0, "use": True})
    force = SLSModel("cubic", 1).predict(TRUTH, sls_data([frame]))
    e = rng.normal(0, sigma, n)
    if noise == "ar1":
        for k in range(1, n):
            e[k] += phi * e[k - 1]
    return sls_data([frame.assign(F=force + e, use=t > 1.0)])


def _exact(data, noise="iid", seed=0, draws=4000):
    model = SLSModel("cubic", 1, noise)
    start = model.space.to_physical(initial_fit(data, model).theta)
    space = SLSSpace("cubic", 1, noise, "identity")
    phi0 = float(start["phi"]) if noise == "ar1" else 0.0
    result, grid = exact_posterior(space, data, float(start["tau"]), phi0=phi0, draws=draws,
                                   seed=seed)  # fmt: skip
    return space, result, grid


def _physical(space, chain):
    return {k: np.asarray(v) for k, v in space.to_physical(chain).items()}


@pytest.fixture(scope="module")
def iid():
    data = _data(11, 6000)
    return data, *_exact(data)


def test_the_exact_posterior_covers_the_truth_with_independent_draws(iid):
    _, space, result, grid = iid
    draws = _physical(space, result.chain)
    for name, true in (TRUTH | {"sigma": 0.02}).items():
        lo, hi = np.quantile(draws[name], [0.001, 0.999])
        assert lo <= true <= hi, (name, lo, true, hi)
    assert result.stop_reason == "exact" and np.all(result.ess == 4000)
    tau, density = grid.marginal("tau")
    assert np.trapezoid(density, np.log(tau)) == pytest.approx(1.0)
    assert density[0] < 1e-6 * density.max() and density[-1] < 1e-6 * density.max()


def test_the_exact_posterior_agrees_with_emcee_on_the_same_data(iid):
    """Two computations of one posterior: the medians agree to a fraction of a posterior sd and
    the 90 % interval widths to 15 % (emcee's priors are weak log-normals, the exact one's flat:
    on these data the difference is far below the sampling error)."""
    data, space, result, _ = iid
    model = SLSModel("cubic", 1, "iid")
    start = initial_fit(data, model)
    chain = run_sampler(model.log_prob_fn(data), start.theta,
                        SamplerConfig(n_walkers=32, max_steps=6000, seed=3),
                        names=model.space.names)  # fmt: skip
    mcmc, exact = _physical(model.space, chain.chain), _physical(space, result.chain)
    for name in ("A_eff", "F0", "k1", "k3", "k2", "tau", "sigma"):
        sd = np.std(exact[name])
        assert abs(np.median(mcmc[name]) - np.median(exact[name])) < 0.25 * sd, name
        width = np.subtract(*np.quantile(exact[name], [0.95, 0.05]))
        other = np.subtract(*np.quantile(mcmc[name], [0.95, 0.05]))
        assert other == pytest.approx(width, rel=0.15), name


def test_ar1_noise_recovers_phi_and_widens_the_intervals():
    data = _data(5, 6000, "ar1")
    space, result, _ = _exact(data, "ar1", draws=2000)
    draws = _physical(space, result.chain)
    lo, hi = np.quantile(draws["phi"], [0.001, 0.999])
    assert lo <= 0.8 <= hi
    for name in ("A_eff", "k1", "k2", "tau"):
        lo, hi = np.quantile(draws[name], [0.001, 0.999])
        assert lo <= TRUTH[name] <= hi, name


def test_same_data_and_seed_give_the_same_draws(iid):
    data, _, result, _ = iid
    _, again, _ = _exact(data)
    np.testing.assert_array_equal(again.chain, result.chain)
    _, other, _ = _exact(data, seed=1)
    assert not np.array_equal(other.chain, result.chain)


def test_several_arms_are_refused_with_the_fix(iid):
    data = iid[0]
    with pytest.raises(ConfigError, match="one Maxwell arm, not 2; use posterior: mcmc"):
        exact_posterior(SLSSpace("cubic", 2, "iid", "identity"), data, 0.2)
