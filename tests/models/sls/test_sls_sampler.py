"""The SLS sampler on toy posteriors with known answers: accuracy, resume, errors, seeding."""

from __future__ import annotations

import emcee
import h5py
import numpy as np
import pytest

from hmid.errors import ConfigError, HmidError
from hmid.models.sls.sampler import (
    SamplerConfig,
    SamplerError,
    SnookerMove,
    run_sampler,
)

NAMES = ("a", "b", "c")


def _regression():
    """y = a + b x + c x^2 + N(0, 0.3^2), flat prior: the posterior is N(mean, cov) exactly."""
    rng = np.random.default_rng(20240601)
    x = np.linspace(0.0, 1.0, 40)
    design = np.column_stack([np.ones_like(x), x, x**2])
    sigma = 0.3
    y = design @ np.array([1.0, -2.0, 3.0]) + sigma * rng.standard_normal(x.size)
    cov = np.linalg.inv(design.T @ design) * sigma**2
    mean = cov @ design.T @ y / sigma**2

    def log_prob(theta):
        residual = y[None, :] - theta @ design.T
        return -0.5 * np.sum(residual**2, axis=1) / sigma**2

    return log_prob, mean, cov


def _banana(theta):
    """A curved 2-D target (Rosenbrock-like), for chains that are not trivially Gaussian."""
    x, y = theta[:, 0], theta[:, 1]
    return -0.5 * x**2 - 0.5 * (y - 0.5 * x**2) ** 2 / 0.3**2


LOG_PROB, MEAN, COV = _regression()
SHORT = SamplerConfig(n_walkers=8, max_steps=700, check_every=100, min_tau_factor=1e6, seed=7)


@pytest.fixture(scope="module")
def converged():
    config = SamplerConfig(n_walkers=16, max_steps=10_000, check_every=100, seed=3)
    return run_sampler(LOG_PROB, MEAN + 0.1, config, names=NAMES)


def test_posterior_matches_exact_regression_posterior(converged):
    """Mean within 4 Monte-Carlo standard errors (sd / sqrt(ESS)); sd within 4 / sqrt(2 ESS)
    relative; correlations within 0.05; converged well inside the step budget."""
    res = converged
    assert res.stop_reason == "converged" and res.converged
    assert res.n_steps < 5_000 and res.n_steps > 50 * np.max(res.tau)
    sd = np.sqrt(np.diag(COV))
    ess = res.ess
    assert np.all(ess > 1000)
    assert np.all(np.abs(res.chain.mean(axis=0) - MEAN) < 4 * sd / np.sqrt(ess))
    assert np.all(np.abs(res.chain.std(axis=0) / sd - 1) < 4 / np.sqrt(2 * ess))
    exact = COV / np.outer(sd, sd)
    np.testing.assert_allclose(np.corrcoef(res.chain.T), exact, atol=0.05)
    assert 0.15 < res.acceptance_mean < 0.6
    assert res.burn_in == int(2 * np.max(res.tau)) and res.thin == max(1, int(np.min(res.tau) / 2))
    assert res.walkers.shape == (res.n_steps, 16, 3)
    assert res.chain.shape[1] == 3 and len(res.log_prob) == len(res.chain)
    assert res.tau_history[-1, 0] == res.n_steps


def test_summary_and_draws(converged):
    table = converged.summary({"a": "N", "b": "N/m", "c": "N/m²"}, confidence=0.9)
    assert list(table.index) == list(NAMES) and table.loc["b", "unit"] == "N/m"
    sd = np.sqrt(np.diag(COV))
    for i, name in enumerate(NAMES):  # 90 % interval of a Gaussian is mean ± 1.645 sd
        row = table.loc[name]
        assert row["lower"] < MEAN[i] < row["upper"]
        assert row["upper"] - row["lower"] == pytest.approx(2 * 1.645 * sd[i], rel=0.1)
    physical = converged.summary(
        {"exp_a": ""}, transform=lambda theta: {"exp_a": np.exp(theta[:, 0])}
    )
    assert physical.loc["exp_a", "median"] == pytest.approx(np.exp(table.loc["a", "median"]))
    with pytest.raises(ConfigError, match="units has no entry for c"):
        converged.summary({"a": "N", "b": "N"})
    first = converged.draws(50, np.random.default_rng(1))
    assert first.shape == (50, 3)
    np.testing.assert_array_equal(first, converged.draws(50, np.random.default_rng(1)))
    assert converged.metrics()["stop_reason"] == "converged"


def test_corrected_snooker_move_samples_a_correlated_gaussian():
    """emcee 3.1.6's DESnookerMove gives sds ~7 % low here; the corrected move must not."""
    cov = np.array([[1.0, 0.9, 0.5], [0.9, 1.0, 0.7], [0.5, 0.7, 1.0]])
    precision = np.linalg.inv(cov)
    sampler = emcee.EnsembleSampler(
        64,
        3,
        lambda th: -0.5 * np.einsum("wi,ij,wj->w", th, precision, th),
        moves=SnookerMove(),
        vectorize=True,
    )
    sampler.random_state = np.random.RandomState(np.random.MT19937(5)).get_state()
    start = np.random.default_rng(0).multivariate_normal(np.zeros(3), cov, size=64)
    sampler.run_mcmc(start, 1000)
    chain = sampler.get_chain(discard=100, flat=True)
    ess = 64 * 900 / sampler.get_autocorr_time(tol=0)
    assert np.all(np.abs(chain.std(axis=0) - 1) < 4 / np.sqrt(2 * ess))


def test_stretch_moves_and_banana_target():
    config = SamplerConfig(n_walkers=16, moves="stretch", max_steps=4000, check_every=200, seed=1)
    res = run_sampler(_banana, np.array([0.1, 0.1]), config, names=["x", "y"])
    # x ~ N(0, 1); y | x ~ N(x²/2, 0.3²) so E[y] = 0.5
    assert abs(res.chain[:, 0].mean()) < 4 / np.sqrt(res.ess[0])
    assert abs(res.chain[:, 1].mean() - 0.5) < 4 * 0.77 / np.sqrt(res.ess[1])


def test_resume_reproduces_a_single_run_bit_for_bit(tmp_path):
    single = run_sampler(_banana, np.array([0.1, 0.2]), SHORT, names=["x", "y"])
    path = tmp_path / "chain.h5"
    first = run_sampler(
        _banana,
        np.array([0.1, 0.2]),
        _with(SHORT, max_steps=250),
        names=["x", "y"],
        backend_path=path,
    )
    assert first.n_steps == 250 and first.stop_reason == "step budget"
    resumed = run_sampler(_banana, np.array([0.1, 0.2]), SHORT, names=["x", "y"], backend_path=path)
    _assert_same_chain(resumed, single)
    stored = emcee.backends.HDFBackend(str(path), read_only=True)  # readable by emcee itself
    np.testing.assert_array_equal(stored.get_chain(), single.walkers)
    # emcee counts the first step too; hmid's acceptance starts after it (read from the chain)
    n = stored.iteration
    assert np.all(np.abs(stored.accepted / n - single.acceptance) <= 1.0 / (n - 1))


def test_resume_after_an_interruption_inside_log_prob(tmp_path):
    single = run_sampler(_banana, np.array([0.1, 0.2]), SHORT, names=["x", "y"])
    path = tmp_path / "chain.h5"
    calls = 0

    def interrupted(theta):
        nonlocal calls
        calls += 1
        if calls == 400:  # mid-chunk: some steps after the last checkpoint
            raise KeyboardInterrupt
        return _banana(theta)

    with pytest.raises(KeyboardInterrupt):
        run_sampler(interrupted, np.array([0.1, 0.2]), SHORT, names=["x", "y"], backend_path=path)
    kept = emcee.backends.HDFBackend(str(path), read_only=True).iteration
    assert kept > 100 and kept % 100 != 0  # the steps before the interruption were saved
    resumed = run_sampler(_banana, np.array([0.1, 0.2]), SHORT, names=["x", "y"], backend_path=path)
    _assert_same_chain(resumed, single)


def test_resume_ignores_a_half_written_checkpoint(tmp_path):
    single = run_sampler(_banana, np.array([0.1, 0.2]), SHORT, names=["x", "y"])
    path = tmp_path / "chain.h5"
    run_sampler(
        _banana,
        np.array([0.1, 0.2]),
        _with(SHORT, max_steps=300),
        names=["x", "y"],
        backend_path=path,
    )
    with h5py.File(path, "a") as f:  # as if killed while writing the newest checkpoint
        f["hmid"].attrs["ckpt_000000000300"] = '{"iteration": 30'
        f["mcmc"].attrs["iteration"] = 123
    resumed = run_sampler(_banana, np.array([0.1, 0.2]), SHORT, names=["x", "y"], backend_path=path)
    _assert_same_chain(resumed, single)


def test_a_converged_chain_file_is_returned_without_sampling(tmp_path):
    path = tmp_path / "chain.h5"
    config = SamplerConfig(n_walkers=16, max_steps=10_000, check_every=100, seed=3)
    first = run_sampler(LOG_PROB, MEAN + 0.1, config, names=NAMES, backend_path=path)
    calls = []

    def counting(theta):
        calls.append(len(theta))
        return LOG_PROB(theta)

    again = run_sampler(counting, MEAN + 0.1, config, names=NAMES, backend_path=path)
    assert again.stop_reason == "converged" and calls == [8, 8]  # only the target check
    _assert_same_chain(again, first)


def test_mismatching_or_foreign_chain_files_are_refused(tmp_path):
    path = tmp_path / "chain.h5"
    config = _with(SHORT, max_steps=100)
    run_sampler(_banana, np.array([0.1, 0.2]), config, names=["x", "y"], backend_path=path)
    with pytest.raises(SamplerError, match=r"different configuration \(differs in seed\).*delete"):
        run_sampler(
            _banana,
            np.array([0.1, 0.2]),
            _with(config, seed=8),
            names=["x", "y"],
            backend_path=path,
        )
    with pytest.raises(SamplerError, match="differs in names"):
        run_sampler(_banana, np.array([0.1, 0.2]), config, names=["u", "v"], backend_path=path)
    with pytest.raises(SamplerError, match="differs in fingerprint"):
        run_sampler(
            _banana,
            np.array([0.1, 0.2]),
            config,
            names=["x", "y"],
            backend_path=path,
            fingerprint="data-v2",
        )
    with pytest.raises(SamplerError, match="the data or model changed"):
        run_sampler(
            lambda th: 2 * _banana(th),
            np.array([0.1, 0.2]),
            config,
            names=["x", "y"],
            backend_path=path,
        )
    foreign = tmp_path / "other.h5"
    with h5py.File(foreign, "w") as f:
        f.create_group("results")
    with pytest.raises(SamplerError, match="not a chain file written by hmid"):
        run_sampler(_banana, np.array([0.1, 0.2]), config, names=["x", "y"], backend_path=foreign)
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    with pytest.raises(SamplerError, match="cannot open as an HDF5 chain file") as info:
        run_sampler(_banana, np.array([0.1, 0.2]), config, names=["x", "y"], backend_path=text)
    # the fix names what a user can do, not a keyword argument no config has
    assert str(info.value).endswith("delete it to sample afresh (hmid run --force does)")
    fresh = run_sampler(
        _banana, np.array([0.1, 0.2]), config, names=["x", "y"], backend_path=text, fresh=True
    )
    assert fresh.n_steps == 100


def test_non_finite_start_is_reported():
    def narrow(theta):  # finite only within 1e-12 of b = 0
        return np.where(np.abs(theta[:, 1]) < 1e-12, _banana(theta), -np.inf)

    with pytest.raises(
        SamplerError,
        match=r"^sampler: 8 of 8 walkers .* non-finite log_prob after 3 re-draws, e\.g\. at x=",
    ):
        run_sampler(narrow, np.array([0.1, 0.0]), SHORT, names=["x", "y"])
    with pytest.raises(SamplerError, match=r"log_prob at theta0 \(x=0.1, y=1\) is -inf"):
        run_sampler(narrow, np.array([0.1, 1.0]), SHORT, names=["x", "y"])
    with pytest.raises(SamplerError, match="theta0 is not finite"):
        run_sampler(_banana, np.array([0.1, np.nan]), SHORT, names=["x", "y"])


def test_ball_scale_sets_the_ball_per_coordinate():
    def box(theta):  # finite only inside |x|, |y| < 1
        return np.where(np.all(np.abs(theta) < 1, axis=1), _banana(theta), -np.inf)

    with pytest.raises(SamplerError, match="shrink the ball"):
        run_sampler(box, np.zeros(2), SHORT, names=["x", "y"], ball_scale=np.array([1e-3, 5.0]))
    res = run_sampler(
        box, np.zeros(2), _with(SHORT, max_steps=1), names=["x", "y"], ball_scale=[0.1, 0.2]
    )
    assert res.n_steps == 1
    with pytest.raises(ConfigError, match="ball_scale must be 2 positive numbers"):
        run_sampler(box, np.zeros(2), SHORT, names=["x", "y"], ball_scale=[0.1, -1.0])


def test_nan_log_prob_counts_as_rejection():
    def holes(theta):
        return np.where(theta[:, 0] > 1.5, np.nan, _banana(theta))

    res = run_sampler(holes, np.array([0.1, 0.2]), _with(SHORT, max_steps=300), names=["x", "y"])
    assert res.n_nan > 0 and np.all(res.walkers[:, :, 0] <= 1.5)


def test_bad_log_prob_output_is_an_error():
    with pytest.raises(SamplerError, match=r"must return shape \(4,\)"):
        run_sampler(lambda th: np.zeros(3), np.array([0.1, 0.2]), SHORT, names=["x", "y"])


def test_budgets_and_stop_reasons():
    res = run_sampler(_banana, np.array([0.1, 0.2]), _with(SHORT, max_steps=50), names=["x", "y"])
    assert res.stop_reason == "step budget" and res.n_steps == 50 and res.burn_in <= 25

    def slow(theta):
        import time

        time.sleep(0.002)
        return _banana(theta)

    config = _with(SHORT, max_steps=10_000, max_seconds=0.1)
    res = run_sampler(slow, np.array([0.1, 0.2]), config, names=["x", "y"])
    assert res.stop_reason == "time budget" and 0 < res.n_steps < 10_000
    assert res.wall_s < 5.0  # 0.1 s budget; generous for a loaded machine


def test_global_numpy_random_state_is_untouched(tmp_path):
    before = np.random.get_state()  # noqa: NPY002 (reading it is the point)
    run_sampler(
        _banana,
        np.array([0.1, 0.2]),
        _with(SHORT, max_steps=200),
        names=["x", "y"],
        backend_path=tmp_path / "c.h5",
    )
    after = np.random.get_state()  # noqa: NPY002
    assert before[0] == after[0] and np.array_equal(before[1], after[1])
    assert before[2:] == after[2:]


def test_seed_decides_the_chain():
    config = _with(SHORT, max_steps=100)
    one = run_sampler(_banana, np.array([0.1, 0.2]), config, names=["x", "y"])
    same = run_sampler(_banana, np.array([0.1, 0.2]), config, names=["x", "y"])
    other = run_sampler(_banana, np.array([0.1, 0.2]), _with(config, seed=8), names=["x", "y"])
    _assert_same_chain(one, same)
    assert not np.array_equal(one.walkers, other.walkers)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"n_walkers": 9}, "n_walkers must be even"),
        ({"n_walkers": 2}, "n_walkers must be an integer >= 4"),
        ({"max_steps": 0}, "max_steps must be an integer >= 1"),
        ({"seed": True}, "seed must be an integer"),
        ({"moves": "walk"}, "moves must be 'de' or 'stretch'"),
        ({"init_scale": 0.0}, "init_scale must be a positive number"),
        ({"tau_rtol": float("nan")}, "tau_rtol must be a positive number"),
    ],
)
def test_config_is_checked(changes, message):
    with pytest.raises(ConfigError, match=message):
        SamplerConfig(**changes)


def test_too_few_walkers_for_the_dimension():
    with pytest.raises(ConfigError, match=r"n_walkers=8 is fewer than 2·D = 10") as info:
        run_sampler(lambda th: np.zeros(len(th)), np.ones(5), SHORT, names="abcde")
    assert isinstance(info.value, HmidError)


def _with(config: SamplerConfig, **changes) -> SamplerConfig:
    from dataclasses import replace

    return replace(config, **changes)


def _assert_same_chain(one, other):
    np.testing.assert_array_equal(one.walkers, other.walkers)
    np.testing.assert_array_equal(one.walkers_log_prob, other.walkers_log_prob)
    np.testing.assert_array_equal(one.acceptance, other.acceptance)
    np.testing.assert_array_equal(one.chain, other.chain)
    np.testing.assert_array_equal(one.tau, other.tau)
