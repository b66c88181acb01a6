"""Moving averages against brute-force references and analytic truth (ramps, sinusoids)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hmid.errors import SignalError
from hmid.signal import Identity, MovingAverage, Smoother, Window, moving_average

DT = 1e-3


def reference(y: np.ndarray, n: int, mode: str, edge: str) -> np.ndarray:
    """The documented edge policies, written out sample by sample (O(n N), small inputs only)."""
    size, h = y.size, (n - 1) // 2
    out = np.empty(size)
    for i in range(size):
        if mode == "centred":
            lo, hi = i - h, i + h + 1
            if edge == "reflect":
                mirrored = np.concatenate([y[::-1], y, y[::-1]])  # c b a | a b c | c b a
                out[i] = mirrored[lo + size : hi + size].mean()
            elif lo >= 0 and hi <= size:
                out[i] = y[lo:hi].mean()
            elif edge == "nan":
                out[i] = np.nan
            else:
                k = min(i, size - 1 - i)
                out[i] = y[i - k : i + k + 1].mean()
        else:
            lo = i - n + 1
            if lo >= 0:
                out[i] = y[lo : i + 1].mean()
            else:
                out[i] = np.nan if edge == "nan" else y[: i + 1].mean()
    return out


# -- Window ----------------------------------------------------------------------------------------
def test_window_in_seconds_rounds_to_nearest_with_halves_up() -> None:
    assert Window(seconds=0.05).samples(DT) == 50
    assert Window(seconds=0.0494).samples(DT) == 49
    assert Window(seconds=1.25).samples(0.5) == 3  # 2.5 exactly -> up
    assert Window(seconds=0.75).samples(0.5) == 2  # 1.5 exactly -> up


def test_centred_window_in_seconds_rounds_up_to_next_odd_but_explicit_even_count_is_an_error() -> (
    None
):
    assert Window(seconds=0.05).samples(DT, odd=True) == 51
    assert Window(seconds=0.051).samples(DT, odd=True) == 51
    assert Window(n_samples=51).samples(odd=True) == 51
    with pytest.raises(SignalError, match="odd number of samples, got 50; use 49 or 51"):
        Window(n_samples=50).samples(odd=True)
    with pytest.raises(SignalError, match="odd number"):
        MovingAverage(50)
    assert MovingAverage(50, mode="causal").window == Window(n_samples=50)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({}, "exactly one"),
        ({"n_samples": 5, "seconds": 0.1}, "exactly one"),
        ({"n_samples": 0}, "positive integer"),
        ({"n_samples": 2.0}, "positive integer"),
        ({"n_samples": True}, "positive integer"),
        ({"seconds": -0.1}, "positive finite"),
        ({"seconds": math.nan}, "positive finite"),
    ],
)
def test_bad_window_is_rejected(kwargs: dict, message: str) -> None:
    with pytest.raises(SignalError, match=message):
        Window(**kwargs)


def test_window_in_seconds_needs_a_sensible_time_step() -> None:
    with pytest.raises(SignalError, match="needs the time step"):
        moving_average(np.zeros(100), Window(seconds=0.01))
    with pytest.raises(SignalError, match="shorter than half a time step"):
        Window(seconds=0.0004).samples(DT)


# -- edge policies ---------------------------------------------------------------------------------
POLICIES = [
    *[("centred", edge, n) for edge in ("shrink", "nan", "reflect") for n in (1, 7, 31, 39)],
    *[("causal", edge, n) for edge in ("shrink", "nan") for n in (1, 2, 7, 8, 40)],
]


@pytest.mark.parametrize(("mode", "edge", "n"), POLICIES)
def test_matches_the_documented_policy_sample_by_sample(mode: str, edge: str, n: int) -> None:
    y = np.random.default_rng(0).normal(size=40)
    # The fast path (running sums, cumulative sums at the edges) and the sample-by-sample
    # reference differ only by rounding: a few ulps of values of order 1.
    np.testing.assert_allclose(
        moving_average(y, n, mode=mode, edge=edge), reference(y, n, mode, edge), atol=1e-14
    )


@pytest.mark.parametrize("n", [1, 5, 51, 201])
def test_centred_shrink_reproduces_constant_and_linear_signals_including_edges(n: int) -> None:
    t = np.arange(201) * DT
    for y in (np.full(t.size, 3.7), 2.0 - 40.0 * t):
        # Every output is the mean of a window symmetric about its sample, which equals the centre
        # value of a linear signal; only rounding (values of order 1) remains.
        np.testing.assert_allclose(moving_average(y, n, mode="centred"), y, rtol=0, atol=1e-12)


def test_causal_shrink_reproduces_constants_exactly() -> None:
    y = np.full(500, -1.25)
    np.testing.assert_allclose(moving_average(y, 40, mode="causal"), y, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("mode", "n", "first", "last"), [("centred", 9, 4, 4), ("causal", 9, 8, 0)]
)
def test_nan_edge_marks_exactly_the_edge_samples(mode: str, n: int, first: int, last: int) -> None:
    out = moving_average(np.ones(30), n, mode=mode, edge="nan")
    expected = np.zeros(30, dtype=bool)
    expected[:first] = True
    expected[30 - last :] = True
    np.testing.assert_array_equal(np.isnan(out), expected)
    np.testing.assert_array_equal(out[~expected], 1.0)


def test_reflect_biases_a_ramp_at_the_ends_as_documented() -> None:
    y = np.arange(50.0)
    out = moving_average(y, 5, edge="reflect")
    np.testing.assert_allclose(out[2:-2], y[2:-2], atol=1e-12)
    assert out[0] == pytest.approx((1 + 0 + 0 + 1 + 2) / 5)  # mirrored: 1 0 | 0 1 2


# -- bad input -------------------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_input_is_an_error_naming_the_first_bad_index(bad: float) -> None:
    y = np.ones(100)
    y[17] = bad
    y[60] = np.nan
    with pytest.raises(SignalError, match=r"y\[17\]"):
        moving_average(y, 5)


def test_window_longer_than_signal_says_both_counts() -> None:
    with pytest.raises(SignalError, match="needs 11 samples but the signal has only 10"):
        moving_average(np.ones(10), 11)
    with pytest.raises(SignalError, match="needs 101 samples but the signal has only 50"):
        MovingAverage(Window(seconds=0.1))(np.arange(50) * DT, np.ones(50))


def test_bad_options_are_rejected() -> None:
    with pytest.raises(SignalError, match="mode must be one of"):
        moving_average(np.ones(10), 3, mode="centered")
    with pytest.raises(SignalError, match="edge must be one of"):
        MovingAverage(3, edge="valid")
    with pytest.raises(SignalError, match="read future samples"):
        MovingAverage(3, mode="causal", edge="reflect")
    with pytest.raises(SignalError, match="must be 1-D"):
        moving_average(np.ones((10, 2)), 3)
    with pytest.raises(SignalError, match="window must be a Window"):
        moving_average(np.ones(10), 3.0)


# -- lag and gain ----------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [10, 11, 50])
def test_causal_filter_delays_a_ramp_by_half_a_window_less_half_a_sample(n: int) -> None:
    t = np.arange(1000) * DT
    slope = 0.3
    out = moving_average(slope * t, n, mode="causal")
    lag_samples = (slope * t - out)[n - 1 :] / (slope * DT)
    np.testing.assert_allclose(lag_samples, (n - 1) / 2, atol=1e-9)


def test_centred_filter_does_not_delay_a_ramp() -> None:
    t = np.arange(1000) * DT
    np.testing.assert_allclose(moving_average(0.3 * t, 51), 0.3 * t, atol=1e-12)


def _amplitude_and_phase(t: np.ndarray, y: np.ndarray, omega: float) -> tuple[float, float]:
    """Least-squares fit y = amp sin(omega t + phase)."""
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t)])
    (s, c), *_ = np.linalg.lstsq(basis, y, rcond=None)
    return float(np.hypot(s, c)), float(np.arctan2(c, s))


@pytest.mark.parametrize("mode", ["centred", "causal"])
def test_sinusoid_gain_and_phase_match_the_moving_average_transfer_function(mode: str) -> None:
    n, f = 51, 5.0  # pi f N dt = 0.80 rad: gain 0.896, far enough from 1 to tell filters apart
    t = np.arange(4000) * DT
    omega = 2 * np.pi * f
    y = np.sin(omega * t)
    out = moving_average(y, n, mode=mode, edge="nan")
    inner = ~np.isnan(out)
    amp, phase = _amplitude_and_phase(t[inner], out[inner], omega)
    gain = abs(np.sin(np.pi * f * n * DT) / (n * np.sin(np.pi * f * DT)))
    lag = 0.0 if mode == "centred" else (n - 1) / 2 * DT
    # Full-window outputs of a pure discrete sinusoid are exactly gain * sin(omega (t - lag)); the
    # fit only adds rounding, so 1e-9 is generous (the brief's 1e-3 holds a fortiori).
    assert amp == pytest.approx(gain, abs=1e-9)
    assert phase == pytest.approx(-omega * lag, abs=1e-9)

    # The cross-correlation of output and input peaks at the filter's lag in samples.
    lags = np.arange(-40, 41)
    core = slice(100, 3900)
    xcorr = [np.dot(out[core], y[core.start - k : core.stop - k]) for k in lags]
    assert lags[int(np.argmax(xcorr))] == round(lag / DT)


# -- strategies ------------------------------------------------------------------------------------
def test_moving_average_strategy_resolves_seconds_with_the_median_step() -> None:
    rng = np.random.default_rng(1)
    t = np.cumsum(np.full(2000, DT))
    t[1000:] += 0.5  # a gap: the median step is still 1 ms
    y = rng.normal(size=t.size)
    smoother = MovingAverage(Window(seconds=0.05))
    assert isinstance(smoother, Smoother)
    np.testing.assert_array_equal(smoother(t, y), moving_average(y, 51))
    causal = MovingAverage(Window(seconds=0.05), mode="causal", edge="nan")
    np.testing.assert_array_equal(causal(t, y), moving_average(y, 50, mode="causal", edge="nan"))


def test_strategies_are_frozen_and_check_their_inputs() -> None:
    smoother = MovingAverage(5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        smoother.edge = "nan"  # type: ignore[misc]
    t, y = np.arange(10) * DT, np.arange(10.0)
    with pytest.raises(SignalError, match="t has 9 samples but the signal has 10"):
        smoother(t[:-1], y)
    with pytest.raises(SignalError, match=r"t\[4\]"):
        smoother(np.r_[t[:4], t[2], t[5:]], y)


def test_identity_returns_a_checked_copy() -> None:
    t, y = np.arange(10) * DT, np.arange(10.0)
    out = Identity()(t, y)
    np.testing.assert_array_equal(out, y)
    assert out is not y
    with pytest.raises(SignalError, match=r"y\[3\]"):
        Identity()(t, np.r_[y[:3], np.nan, y[4:]])


# -- long signals ----------------------------------------------------------------------------------
def test_long_signal_with_large_offset_keeps_full_precision() -> None:
    # A global cumulative sum of 1e6 samples near 1e6 reaches 1e12, so differences of it lose
    # about 1e-11 relative (measured 7e-12); a running sum stays near 1e-13. Reference: exact fsum.
    rng = np.random.default_rng(2)
    y = 1e6 + rng.normal(size=1_000_000)
    n, h = 101, 50
    out = moving_average(y, n)
    idx = rng.integers(h, y.size - h, size=200)
    exact = np.array([math.fsum(y[i - h : i + h + 1]) / n for i in idx])
    assert np.max(np.abs(out[idx] - exact)) / 1e6 < 1e-12


def test_passes_cascade_the_box_into_a_smooth_kernel():
    t = np.arange(201) * 1e-3
    impulse = np.zeros(201)
    impulse[100] = 1.0
    three = MovingAverage(Window(5), passes=3)(t, impulse)
    box = np.ones(5) / 5
    np.testing.assert_allclose(three[94:107], np.convolve(np.convolve(box, box), box), atol=1e-15)
    assert three.sum() == pytest.approx(1.0)
    with pytest.raises(SignalError, match="passes must be an integer >= 1"):
        MovingAverage(Window(5), passes=0)


@pytest.mark.parametrize(
    "smoother",
    [
        Identity(),
        MovingAverage(Window(seconds=0.011), passes=3),
        MovingAverage(5, mode="causal"),
        MovingAverage(7, edge="reflect"),
    ],
)
def test_a_smoother_bound_to_a_time_base_smooths_exactly_as_called_with_it(smoother):
    t = np.cumsum(np.full(500, 1e-3))
    y = np.sin(40 * t) + np.random.default_rng(3).normal(0, 0.1, t.size)
    smooth = smoother.on(t)
    np.testing.assert_array_equal(smooth(y), smoother(t, y))
    with pytest.raises(SignalError):
        smooth(np.append(y, 0.0) if isinstance(smoother, MovingAverage) else y[:, None])
