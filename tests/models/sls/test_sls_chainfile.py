"""The chain file as a source of truth: every stored row verified, results that do not depend on
what the file holds, one writer at a time, and Ctrl-C said in one line."""

from __future__ import annotations

import threading
import warnings
from dataclasses import replace

import h5py
import numpy as np
import pytest

from hmid.errors import HmidError, HmidWarning
from hmid.models.sls.sampler import SamplerConfig, SamplingInterrupted, run_sampler

START = np.array([0.1, 0.2])
SHORT = SamplerConfig(n_walkers=8, max_steps=700, check_every=100, min_tau_factor=1e6, seed=7)
SETTLING = SamplerConfig(n_walkers=8, max_steps=20_000, check_every=100, min_tau_factor=20, seed=7)


def _banana(theta):
    x, y = theta[:, 0], theta[:, 1]
    return -0.5 * x**2 - 0.5 * (y - 0.5 * x**2) ** 2 / 0.3**2


def _run(config, path=None, log_prob=_banana, **kw):
    return run_sampler(log_prob, START, config, names=["x", "y"], backend_path=path, **kw)


def _same(one, other):
    assert one.n_steps == other.n_steps and one.stop_reason == other.stop_reason
    for name in ("walkers", "walkers_log_prob", "chain", "tau", "acceptance"):
        np.testing.assert_array_equal(getattr(one, name), getattr(other, name))


def test_an_altered_row_anywhere_in_the_stored_chain_is_caught_and_resampled(tmp_path):
    single = _run(SHORT)
    path = tmp_path / "chain.h5"
    _run(replace(SHORT, max_steps=400), path)
    with h5py.File(path, "a") as f:  # one early row, far from the last one a checkpoint names
        f["mcmc/chain"][37, 3, 0] += 0.5
    with pytest.warns(HmidWarning, match=r"chain\.h5: the stored chain does not match"):
        resumed = _run(SHORT, path)
    assert resumed.reused_steps == 0  # nothing was trusted
    _same(resumed, single)


def test_a_longer_budget_chain_is_read_as_the_shorter_run_would_stop(tmp_path):
    """Same config and seed, same numbers, whatever the file holds: a 1,000-step budget next to
    a chain left by a 20,000-step run stops at its own budget, not at the other's convergence."""
    budget = replace(SETTLING, max_steps=1000)
    fresh = _run(budget)
    assert fresh.stop_reason == "step budget" and fresh.n_steps == 1000
    path = tmp_path / "chain.h5"
    long = _run(SETTLING, path)
    assert long.stop_reason == "converged" and long.n_steps > 1000
    reread = _run(budget, path)
    _same(reread, fresh)
    assert reread.reused_steps == 1000


def test_a_chain_converged_under_other_settings_is_replayed_under_these(tmp_path):
    strict = replace(SETTLING, min_tau_factor=60)
    fresh = _run(strict)
    path = tmp_path / "chain.h5"
    loose = _run(SETTLING, path)
    assert loose.n_steps < fresh.n_steps  # the stored chain stops short of the strict rule
    reread = _run(strict, path)
    _same(reread, fresh)
    assert reread.reused_steps == loose.n_steps


def test_a_second_writer_waits_instead_of_deleting_the_first_ones_chain(tmp_path):
    path = tmp_path / "chain.h5"
    results, errors = [], []

    def slow(theta):
        threading.Event().wait(0.0005)
        return _banana(theta)

    def one():
        try:
            results.append(_run(SHORT, path, log_prob=slow, fresh=True))
        except BaseException as err:  # the thread's failure must fail the test
            errors.append(err)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        threads = [threading.Thread(target=one) for _ in range(2)]
        for t in threads:
            t.start()
            threading.Event().wait(0.2)
        for t in threads:
            t.join()
    assert not errors
    _same(results[0], results[1])
    assert any("another run is sampling this chain" in str(w.message) for w in caught)


def test_ctrl_c_during_sampling_says_where_the_chain_is_saved_in_one_line(tmp_path, capsys):
    path = tmp_path / "chain.h5"
    calls = 0

    def interrupted(theta):
        nonlocal calls
        calls += 1
        if calls == 400:
            raise KeyboardInterrupt
        return _banana(theta)

    with pytest.raises(SamplingInterrupted) as info:
        _run(SHORT, path, log_prob=interrupted)
    message = str(info.value)
    assert isinstance(info.value, HmidError) and "\n" not in message
    assert f"saved at step {info.value.step} in {path}" in message and info.value.step > 100
    assert "run the same command again to resume" in message
    assert "emcee" not in capsys.readouterr().out  # no parameter dump from emcee's wrapper
