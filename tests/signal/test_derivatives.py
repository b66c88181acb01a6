"""Velocity and acceleration estimates against analytic truth.

Scenario (a Hydro Muscle stroke): x(t) = A sin(2 pi f t), A = 5 mm, f = 1 Hz, sampled at 1 kHz for
10 s, plus Gaussian noise sigma = 0.02 mm, then quantised to steps of q = 0.02 mm (10-bit-style).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.signal import savgol_coeffs

from hmid.errors import SignalError
from hmid.signal import (
    MAX_STEP_JITTER,
    Differentiator,
    Identity,
    MovingAverage,
    SavitzkyGolay,
    SmoothedFiniteDifference,
    Window,
    estimate_motion,
)

A, F, DT, DURATION = 5e-3, 1.0, 1e-3, 10.0
SIGMA, Q = 2e-5, 2e-5
OMEGA = 2 * np.pi * F
# Quantisation with a step no larger than the Gaussian noise acts as independent uniform noise of
# variance q^2 / 12, so the position error is white with this standard deviation.
SIGMA_TOTAL = float(np.hypot(SIGMA, Q / np.sqrt(12)))
WINDOW = Window(seconds=0.1)  # 101 samples: a tenth of the period
N = 101
STRATEGIES = {
    "savitzky-golay": SavitzkyGolay(WINDOW, polyorder=3),
    "smoothed-fd": SmoothedFiniteDifference(MovingAverage(WINDOW)),
}
# Samples dropped at each end before judging accuracy: one window for Savitzky-Golay, two for the
# smoothed finite difference (smoothed twice), as the module docstring advises.
MARGIN = {"savitzky-golay": N, "smoothed-fd": 2 * N}


def measured_position(t: np.ndarray, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return Q * np.round((A * np.sin(OMEGA * t) + rng.normal(0.0, SIGMA, t.size)) / Q)


def true_derivative(t: np.ndarray, order: int) -> np.ndarray:
    return A * OMEGA**order * (np.cos(OMEGA * t) if order == 1 else -np.sin(OMEGA * t))


def predicted_rms_error(d: Differentiator, t: np.ndarray, order: int) -> float:
    """RMS error of a linear, shift-invariant estimator on the scenario, from its impulse response.

    Away from the edges both strategies are linear filters with an impulse response h on a uniform
    grid. On A sin(omega t) the filter's output differs from the true derivative by
    A |H(omega) - (i omega)^order| / sqrt(2) (RMS), and white noise of standard deviation s adds
    s * ||h||_2 (uncorrelated with the signal, so the two add in quadrature).
    """
    j, k = t.size // 2, np.arange(-4 * N, 4 * N + 1)
    impulse = np.zeros(t.size)
    impulse[j] = 1.0
    h = d.derivative(t, impulse, order)[j + k]
    response = np.sum(h * np.exp(-1j * OMEGA * k * DT))
    bias = A * abs(response - (1j * OMEGA) ** order) / np.sqrt(2)
    noise = SIGMA_TOTAL * np.sqrt(np.sum(h**2))
    return float(np.hypot(bias, noise))


@pytest.mark.parametrize("name", list(STRATEGIES))
@pytest.mark.parametrize(("order", "budget"), [(1, 0.02), (2, 0.05)])
def test_accuracy_on_noisy_quantised_sinusoid(name: str, order: int, budget: float) -> None:
    d = STRATEGIES[name]
    t = np.arange(round(DURATION / DT)) * DT
    estimate = d.derivative(t, measured_position(t, seed=7), order)
    inner = slice(MARGIN[name], -MARGIN[name])
    rms = np.sqrt(np.mean((estimate - true_derivative(t, order))[inner] ** 2))
    # Brief's budget: 2 % of the velocity amplitude, 5 % of the acceleration amplitude. Predicted
    # (bias, noise) in % of amplitude: SG v (0.001, 0.57), a (0.51, 2.76); smoothed FD
    # v (1.18, 0.66), a (2.34, 1.55) -- the FD bias is the moving-average gain
    # sin(pi f N dt) / (N sin(pi f dt)), once for v and squared for a.
    assert rms < budget * A * OMEGA**order
    # The error must also match its prediction. The noise is correlated over ~N samples, so the
    # ~9,600 interior samples hold ~100 independent stretches: the RMS of the noise part scatters by
    # ~1/sqrt(200) = 7 %; over 20 seeds the ratio stayed in 0.95-1.10. +-15 % is ~2 sigma.
    assert rms == pytest.approx(predicted_rms_error(d, t, order), rel=0.15)


def test_smoothed_finite_difference_handles_uneven_steps() -> None:
    # Steps jitter uniformly by +-20 % (relative std 11.5 %, far over Savitzky-Golay's 1 % limit).
    # Smoothing t along with y keeps values and times paired, so the error should stay that of a
    # uniform grid (measured within 1 %); differentiating against the raw t gives 6 % (v), 13 % (a).
    rng = np.random.default_rng(11)
    n = round(DURATION / DT)
    t = np.concatenate([[0.0], np.cumsum(DT * (1 + 0.2 * rng.uniform(-1, 1, n - 1)))])
    d = STRATEGIES["smoothed-fd"]
    v, a = estimate_motion(t, measured_position(t, seed=12), d)
    inner = slice(2 * N, -2 * N)
    uniform = np.arange(n) * DT
    for order, est in ((1, v), (2, a)):
        rms = np.sqrt(np.mean((est - true_derivative(t, order))[inner] ** 2))
        assert rms < 1.15 * predicted_rms_error(d, uniform, order)
    with pytest.raises(
        SignalError, match="resample the log or use derivative kind 'smoothed_difference'"
    ):
        STRATEGIES["savitzky-golay"].derivative(t, measured_position(t, seed=12))


def test_savitzky_golay_accepts_small_timestamp_jitter_and_refuses_more() -> None:
    rng = np.random.default_rng(5)
    for jitter, ok in ((0.5 * MAX_STEP_JITTER, True), (2 * MAX_STEP_JITTER, False)):
        # uniform on [-w, w] has std w / sqrt(3)
        steps = DT * (1 + np.sqrt(3) * jitter * rng.uniform(-1, 1, 999))
        t = np.concatenate([[0.0], np.cumsum(steps)])
        if ok:
            assert np.isfinite(SavitzkyGolay(11).derivative(t, np.sin(t))).all()
        else:
            with pytest.raises(SignalError, match="uniform sampling"):
                SavitzkyGolay(11).derivative(t, np.sin(t))


# -- exact cases -----------------------------------------------------------------------------------
@pytest.mark.parametrize("window", [5, 11, Window(seconds=0.1)])
def test_savitzky_golay_is_exact_on_cubics_including_edges(window: Window | int) -> None:
    t = 0.5 + np.arange(2001) * DT
    y = 1 + 2 * t - 3 * t**2 + 0.5 * t**3
    sg = SavitzkyGolay(window, polyorder=3)
    # Exact in exact arithmetic; rounding of O(1) values is amplified by ||coeffs||_1 ~ 1/dt for
    # the velocity (~1e-13 measured) and ~1/dt^2 for the acceleration (~1e-10 measured).
    np.testing.assert_allclose(sg.derivative(t, y, 1), 2 - 6 * t + 1.5 * t**2, rtol=0, atol=1e-11)
    np.testing.assert_allclose(sg.derivative(t, y, 2), -6 + 3 * t, rtol=0, atol=1e-8)


def test_smoothed_finite_difference_is_exact_on_lines_including_edges() -> None:
    t = np.arange(500) * DT
    d = SmoothedFiniteDifference(MovingAverage(51))
    v, a = estimate_motion(t, 0.2 - 3.0 * t, d)
    # The symmetric shrinking window returns a line unchanged and differences of a line are exact;
    # rounding of O(1) values divided by dt once leaves ~3e-12 (measured), twice ~2e-10.
    np.testing.assert_allclose(v, -3.0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(a, 0.0, rtol=0, atol=1e-8)


def test_gradient_uses_the_uneven_time_base() -> None:
    # np.gradient's interior formula on uneven steps is exact for quadratics; treating the grid as
    # uniform would be off by about the step jitter (30 %).
    rng = np.random.default_rng(9)
    t = np.cumsum(DT * (1 + 0.3 * rng.uniform(-1, 1, 300)))
    v = SmoothedFiniteDifference(Identity()).derivative(t, 4.0 * t**2 - t)
    np.testing.assert_allclose(v[1:-1], (8.0 * t - 1)[1:-1], rtol=0, atol=1e-9)


# -- edges -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(STRATEGIES))
def test_edges_are_finite(name: str) -> None:
    t = np.arange(round(DURATION / DT)) * DT
    v, a = estimate_motion(t, measured_position(t, seed=3), STRATEGIES[name])
    assert np.isfinite(v).all()
    assert np.isfinite(a).all()


@pytest.mark.parametrize("order", [1, 2])
def test_savitzky_golay_edge_error_is_bounded_by_the_off_centre_noise_gain(order: int) -> None:
    # At the edges, sample i uses the fit of the first window evaluated at position i; its noise is
    # sigma * ||c_i||. The RMS over the first and last windows cannot exceed the worst of those by
    # much (bias is ~0.5 % of amplitude here); 1.2 x covers scatter over 2 x 101 samples.
    t = np.arange(round(DURATION / DT)) * DT
    est = STRATEGIES["savitzky-golay"].derivative(t, measured_position(t, seed=4), order)
    err = est - true_derivative(t, order)
    edge_rms = np.sqrt(np.mean(np.r_[err[:N], err[-N:]] ** 2))
    worst = max(
        np.linalg.norm(savgol_coeffs(N, 3, deriv=order, delta=DT, pos=pos)) for pos in range(N)
    )
    assert edge_rms < 1.2 * SIGMA_TOTAL * worst


# -- contract and errors ---------------------------------------------------------------------------
def test_estimate_motion_is_first_and_second_derivative() -> None:
    t = np.arange(300) * DT
    x = np.sin(7 * t)
    for d in STRATEGIES.values():
        v, a = estimate_motion(t, x, d)
        np.testing.assert_array_equal(v, d.derivative(t, x, 1))
        np.testing.assert_array_equal(a, d.derivative(t, x, 2))
    with pytest.raises(SignalError, match="must be a Differentiator"):
        estimate_motion(t, x, MovingAverage(5))  # type: ignore[arg-type]


def test_differentiators_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        STRATEGIES["savitzky-golay"].polyorder = 2  # type: ignore[misc]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: SavitzkyGolay(10), "odd number"),
        (lambda: SavitzkyGolay(5, polyorder=5), "window of more than 5 samples, got 5"),
        (lambda: SavitzkyGolay(5, polyorder=-1), "non-negative integer"),
        (lambda: SmoothedFiniteDifference(MovingAverage(5, edge="nan")), "edge='shrink'"),
        (lambda: SmoothedFiniteDifference(5), "must be a Smoother"),
    ],
)
def test_bad_configuration_is_rejected_at_construction(make, message: str) -> None:
    with pytest.raises(SignalError, match=message):
        make()


def test_bad_calls_are_rejected() -> None:
    t = np.arange(50) * DT
    y = np.sin(t)
    with pytest.raises(SignalError, match="order must be 1 or 2, got 3"):
        SavitzkyGolay(5).derivative(t, y, order=3)
    with pytest.raises(SignalError, match="degree 1 cannot give derivative 2"):
        SavitzkyGolay(5, polyorder=1).derivative(t, y, order=2)
    with pytest.raises(SignalError, match="needs 101 samples but the signal has only 50"):
        SavitzkyGolay(WINDOW).derivative(t, y)
    with pytest.raises(SignalError, match=r"y\[20\]"):
        SavitzkyGolay(5).derivative(t, np.where(np.arange(50) == 20, np.nan, y))
    with pytest.raises(SignalError, match=r"t\[10\]"):
        SavitzkyGolay(5).derivative(np.r_[t[:10], t[:40]], y)


# -- derivatives of the smoothed signal ------------------------------------------------------
def test_derivatives_of_the_smoothed_signal_see_exactly_its_filter():
    from hmid.signal import DerivativeOfSmoothed

    t = np.arange(0, 4, 1e-3)
    w = 2 * np.pi * 5.0
    smoother = MovingAverage(Window(seconds=0.025), passes=3)
    diff = DerivativeOfSmoothed(smoother)
    inner = slice(200, -200)
    # differencing commutes with the filter: d/dt of the smoothed sine is the smoothed cosine,
    # up to the central difference's (w dt)^2 / 6 (1e-4 at 5 Hz)
    v = diff.derivative(t, np.sin(w * t), 1)
    np.testing.assert_allclose(
        v[inner], smoother(t, w * np.cos(w * t))[inner], rtol=0, atol=2e-4 * w
    )
    a = diff.derivative(t, np.sin(w * t), 2)
    reference = smoother(t, -(w**2) * np.sin(w * t))
    np.testing.assert_allclose(a[inner], reference[inner], rtol=0, atol=1e-4 * w**2)
    assert diff.includes(smoother) and not SavitzkyGolay(Window(51)).includes(smoother)


def test_the_second_difference_is_exact_for_a_parabola_on_uneven_steps():
    from hmid.signal import DerivativeOfSmoothed, Identity

    t = np.cumsum(np.random.default_rng(3).uniform(0.8e-3, 1.2e-3, 500))
    a = DerivativeOfSmoothed(Identity()).derivative(t, 3.0 * t**2, 2)
    np.testing.assert_allclose(a[1:-1], 6.0, rtol=1e-6)


@pytest.mark.parametrize("extra", [1, 2, 3, 777])
def test_a_long_signal_is_differentiated_by_blocks_to_the_same_numbers(extra):
    from hmid.signal import DerivativeOfSmoothed
    from hmid.signal.blocks import BLOCK
    from hmid.signal.derivatives import _difference

    rng = np.random.default_rng(extra)
    n = 2 * BLOCK + extra  # a last block of one sample needs its two neighbours
    t = np.cumsum(rng.uniform(0.95e-3, 1.05e-3, n))
    x = np.sin(2 * np.pi * 3 * t) + 1e-3 * rng.normal(size=n)
    differentiator = DerivativeOfSmoothed(MovingAverage(9, passes=3))
    smoothed = MovingAverage(9, passes=3)(t, x)
    for order in (1, 2):
        got = differentiator.derivative(t, x, order)
        np.testing.assert_array_equal(got, _difference(t, smoothed, order))
