"""Every declared term kind: its columns carry the term's sign, unit and physical sign; each kind
computes what its docstring says (checked against closed forms)."""

import numpy as np
import pytest
from _balance_data import motion, signals_with

from hmid.balance import TERM_KINDS, ModelSlot, make_term
from hmid.balance.kinds import Grid, LagTerm, MemoryTerm
from hmid.balance.operations import memory_arms
from hmid.errors import ConfigError

KINDS = sorted(k for k in TERM_KINDS if k != "model")


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_gives_signed_finite_columns_with_units(kind):
    signals = signals_with()
    term = TERM_KINDS[kind].example()
    assert make_term(term.model_dump(by_alias=True)) == term  # round-trips through its config
    hyper = term.hyper
    values = hyper.grid[:: max(len(hyper.grid) // 3, 1)] if hyper else (None,)
    for value in values:
        columns = term.columns(signals, value)
        assert columns.names == (term.name,) and columns.values.shape == (len(signals), 1)
        assert np.isfinite(columns.values).all()
        assert np.ptp(columns.values) > 0 or term.reads == ()  # only a constant is constant
        assert columns.units[0] and columns.positive == (term.positive,)
        assert set(columns.reads[0]) == set(term.reads)
        flipped = term.model_copy(update={"sign": -term.sign}).columns(signals, value)
        np.testing.assert_array_equal(flipped.values, -columns.values)


def test_the_model_slot_has_no_columns_of_its_own():
    with pytest.raises(TypeError, match="a model family fills it"):
        ModelSlot().columns(signals_with(), None)


def test_channel_powers_and_products():
    signals = signals_with()
    x, P = signals["x"], signals["P"]
    term = make_term({"kind": "channel", "name": "c", "channel": "x^2*P"})
    np.testing.assert_allclose(term.columns(signals, None).values[:, 0], x**2 * P)
    assert term.columns(signals, None).units == ("N/(Pa·m²)",)
    with pytest.raises(ConfigError, match="cannot read term"):
        make_term({"kind": "channel", "name": "c", "channel": "x**2"})


def test_a_memory_arm_is_the_exact_response_and_interpolates_between_grid_points():
    signals = signals_with()
    frame = motion()
    seg = frame["segment"].to_numpy() == 0
    t, v = frame["t"].to_numpy()[seg], frame["v"].to_numpy()[seg]
    tau = 0.2
    # dg/dt = -g/tau + dx/dt from rest; x is smooth, so a fine Euler solve is the reference
    g, ref = 0.0, np.empty(seg.sum())
    for k in range(len(t)):
        if k:
            dt = t[k] - t[k - 1]
            g = g * np.exp(-dt / tau) + tau * (1 - np.exp(-dt / tau)) * 0.5 * (v[k] + v[k - 1])
        ref[k] = g
    exact = memory_arms(signals, "x", (tau,))[0][seg]
    assert np.max(np.abs(exact - ref)) < 1e-4 * np.ptp(ref)  # 2 ms steps, x piecewise linear
    term = MemoryTerm(name="k2", channel="x", tau=Grid(min=0.01, max=5.0, points=40))
    between = term.columns(signals, 0.2017).values[:, 0]  # off the grid: interpolated
    direct = memory_arms(signals, "x", (0.2017,))[0]
    assert np.max(np.abs(between - direct)) < 3e-5 * np.ptp(direct)


def test_a_delay_is_the_channel_earlier_and_leaves_a_margin():
    signals = signals_with()
    term = LagTerm(name="A", channel="P", filter="delay", time=0.02)
    shifted = term.columns(signals, None).values[:, 0]
    t, P = signals["t"], signals["P"]
    seg = signals["segment"] == 0
    inside = seg & (t > 0.05)
    np.testing.assert_allclose(shifted[inside], np.interp(t[inside] - 0.02, t[seg], P[seg]))
    assert term.margins == (0.02, 0.0)
    lag = LagTerm(name="A", channel="P", filter="first_order", time=0.05)
    smooth = lag.columns(signals, None).values[:, 0]
    assert np.std(np.diff(smooth[seg])) < np.std(np.diff(P[seg]))  # a low-pass, started steady


def test_coulomb_is_the_sign_of_the_velocity_estimate_through_the_smoother():
    signals = signals_with()
    term = make_term({"kind": "coulomb", "name": "Fc", "sign": -1})
    column = term.columns(signals, None).values[:, 0]
    np.testing.assert_array_equal(column, -np.sign(signals["raw:v"]))  # no smoother here
    assert term.positive and term.regressor() == "sign(v)"


def test_a_power_of_a_logged_channel_is_smoothed_after_it_is_evaluated():
    """The measured force holds S[k3 x³] (the smoother S acts on the force); the regressor must
    be S[x_raw³], not (S x)³: their difference, ≈ 3x·var(x) within the kernel, is even in v and
    was read by the loop as direction-dependent Stribeck friction on the knee rig."""
    from hmid.balance.signals import Signals
    from hmid.balance.structure import Structure, fit_structure
    from hmid.signal import MovingAverage

    smoother = MovingAverage(window=25, passes=3)
    plain = signals_with()
    frame = plain.frame.copy()  # raw:x is the exact x; x becomes its smoothed version
    t = frame["t"].to_numpy()
    frame["x"] = np.concatenate(
        [smoother(t[r], frame["raw:x"].to_numpy()[r]) for r in plain.segments()]
    )
    signals = Signals(frame, plain.units, plain.channels, plain.position, smoother)
    k3 = 2e6
    signals = signals.with_columns(target=-k3 * signals.smooth(signals["raw:x"] ** 3))
    term = make_term({"kind": "channel", "name": "k3", "channel": "x^3", "sign": -1})
    result = fit_structure(Structure.of([term]), signals)
    assert result.params["k3"] == pytest.approx(k3, rel=1e-9)
    usable = signals.usable
    assert np.max(np.abs(result.residual[usable])) < 1e-9 * k3 * 0.02**3
    cube_of_smoothed = -k3 * signals["x"] ** 3  # what the term used to read: visibly off
    assert np.max(np.abs((signals.target - cube_of_smoothed)[usable])) > 1e-3
