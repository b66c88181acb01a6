"""The free run's band: its quantiles, and the disturbance scale calibrated on training blocks
against cases whose answer is known (an error that is the disturbance's response times a known
factor; a coefficient band that covers alone; a disturbance that moves nothing)."""

import warnings

import numpy as np
import pytest

from hmid.portable.freerun import calibrate, chunks
from hmid.portable.freerun.band import quantile_band


def test_the_band_is_numpys_quantile_of_the_draws_that_did_not_diverge():
    runs = np.random.default_rng(0).normal(size=(20, 300))
    runs[3, 100:] = np.nan  # a draw that diverged at sample 100
    runs[5, 7] = np.inf
    runs[:, 250:] = np.nan  # every draw diverged: no band
    lower, upper = quantile_band(runs, 0.9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        expected = np.nanquantile(np.where(np.isfinite(runs), runs, np.nan), [0.05, 0.95], 0)
    np.testing.assert_allclose(lower, expected[0], atol=1e-15)
    np.testing.assert_allclose(upper, expected[1], atol=1e-15)
    assert np.isnan(lower[250:]).all() and np.isfinite(lower[:250]).all()


def _chunk(rng, n: int, draws: int, error_scale: float, coefficient_scale: float = 0.0):
    """A training block whose measured position leaves the nominal run by a disturbance
    response ``error_scale`` times as large as the scale-1 draws'."""
    nominal = np.zeros(n)
    d = rng.normal(size=(draws, n))
    c = coefficient_scale * rng.normal(size=(draws, n))
    measured = error_scale * rng.normal(size=n)
    return measured, nominal, c, d


def test_the_disturbance_scale_is_the_factor_that_covers_the_level():
    rng = np.random.default_rng(1)
    found = calibrate([_chunk(rng, 4000, 200, 3.0) for _ in range(3)], 0.9)
    assert found.reachable and found.coverage == pytest.approx(0.9, abs=0.005)
    assert found.scale == pytest.approx(3.0, rel=0.05)


def test_a_coefficient_band_that_covers_alone_adds_no_disturbance():
    rng = np.random.default_rng(2)
    found = calibrate([_chunk(rng, 2000, 100, 1.0, coefficient_scale=3.0)], 0.9)
    assert found.scale == 0.0 and found.coverage > 0.9


def test_a_disturbance_that_moves_nothing_cannot_reach_the_level_and_says_so():
    rng = np.random.default_rng(3)
    measured, nominal, c, d = _chunk(rng, 1000, 50, 1.0)
    found = calibrate([(measured, nominal, c, 0 * d)], 0.9)
    assert not found.reachable and found.coverage < 0.1


def test_a_nominal_run_that_diverged_is_read_without_a_warning():
    """A training piece whose nominal run diverged (inf; the draws' deviations from it -inf):
    its samples count as not covered, and nothing reaches the user's console as a warning."""
    rng = np.random.default_rng(5)
    measured, nominal, c, d = _chunk(rng, 1000, 50, 1.0)
    nominal[600:], c[:, 600:] = np.inf, -np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        found = calibrate([(measured, nominal, c, d)], 0.9)
    assert not found.reachable and found.coverage <= 0.6


def test_training_blocks_are_cut_to_the_held_out_length():
    pieces = chunks([np.arange(100), np.arange(200, 225), np.arange(300, 305)], 40)
    assert [len(p) for p in pieces] == [40, 40, 20, 25]  # the 5-row block: too short
    assert np.array_equal(np.concatenate(pieces[:3]), np.arange(100))


def test_a_drift_is_a_random_walk_whose_variance_grows_as_the_time_run():
    from hmid.portable.freerun.band import drifts

    t = np.linspace(0.0, 4.0, 401)
    walks = drifts(t, 20000, np.random.default_rng(4))
    assert np.all(walks[:, 0] == 0)
    np.testing.assert_allclose(walks[:, [100, 400]].var(axis=0), [1.0, 4.0], rtol=0.05)


def _shaped(rng, shape: str, n: int = 600, draws: int = 40):
    """A training chunk whose error has ``shape``: a random walk ("drift") or stationary
    noise ("force"); returned as the force's chunk (stationary D) and the drift's (walks)."""
    from hmid.portable.freerun.band import drifts

    t = np.arange(n) / 100.0
    walk = drifts(t, draws + 1, rng)
    noise = rng.normal(size=(draws + 1, n))
    error = 0.3 * (walk[0] if shape == "drift" else noise[0])
    zeros = np.zeros((draws, n))
    return (error, np.zeros(n), zeros, noise[1:]), (error, np.zeros(n), zeros, walk[1:])


@pytest.mark.parametrize("shape", ["drift", "force"])
def test_the_training_blocks_choose_the_shape_of_their_own_error(shape):
    from hmid.portable.freerun.band import DRIFT, FORCE, choose

    rng = np.random.default_rng(5)
    pairs = [_shaped(rng, shape) for _ in range(16)]
    found = choose([f for f, _ in pairs], [d for _, d in pairs], 0.9)
    assert found.kind == (DRIFT if shape == "drift" else FORCE)
    assert found.reachable and found.coverage == pytest.approx(0.9, abs=0.01)
    assert found.miss < 0.1  # cross-calibrated, by horizon: within 10 points


def _family(rng, count: int, spread: float, n: int = 400, draws: int = 40) -> list:
    """``count`` training blocks whose error scales vary from block to block (log-normal with
    ``spread``), as a rig's do from one excitation to the next."""
    return [_chunk(rng, n, draws, float(np.exp(spread * rng.normal()))) for _ in range(count)]


def test_the_target_is_raised_by_what_a_left_out_block_misses():
    """Blocks alike: the leave-one-out loss is nil and the target is the level. Blocks whose
    error scale varies: a scale calibrated on eight of them covers new blocks of the same kind
    less than the level; calibrated to the raised target, nearer it (over 20 training sets)."""
    from hmid.portable.freerun.band import coverage_of, held_out_target

    rng = np.random.default_rng(6)
    alike = _family(rng, 16, 0.0, n=2000, draws=100)
    assert held_out_target(alike, 0.9, calibrate(alike, 0.9).scale) <= 0.905
    at_level, raised, targets = [], [], []
    new = _family(rng, 200, 0.7)
    for _ in range(20):
        training = _family(rng, 8, 0.7)
        target = held_out_target(training, 0.9, calibrate(training, 0.9).scale)
        targets.append(target)
        at_level.append(coverage_of(new, 0.9, calibrate(training, 0.9).scale))
        raised.append(coverage_of(new, 0.9, calibrate(training, 0.9, target=target).scale))
    assert np.mean(targets) > 0.91
    assert np.mean(at_level) < 0.89  # the level's own scale: too narrow away from its blocks
    assert abs(np.mean(raised) - 0.9) < 0.5 * abs(np.mean(at_level) - 0.9)


def test_too_few_blocks_keep_the_level():
    from hmid.portable.freerun.band import choose

    rng = np.random.default_rng(7)
    pairs = [_shaped(rng, "force") for _ in range(2)]
    found = choose([f for f, _ in pairs], [d for _, d in pairs], 0.9)
    assert found.target == 0.9
