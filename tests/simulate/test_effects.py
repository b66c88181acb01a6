"""Each extra effect changes the signals it should, visibly, and nothing else; and its physics."""

import numpy as np
import pytest

from hmid.errors import ConfigError
from hmid.simulate.dataset import DatasetConfig, DynamicLog, simulate_log
from hmid.simulate.effects import EFFECTS, make_effect
from hmid.simulate.params import Sensors
from hmid.simulate.profiles import Sine

SENSORS = Sensors()
PROFILE = Sine(offset=1.4e5, amplitude=1.0e5, frequency=0.5)


def _simulate(effects=(), duration=6.0, seed=3):
    spec = DynamicLog(name="e", duration=duration, profile=PROFILE, effects=tuple(effects))
    return simulate_log(DatasetConfig(seed=seed, logs=(spec,)), spec)


@pytest.fixture(scope="module")
def clean():
    return _simulate()


STRONG = {  # strengths a real rig could show, large enough to be seen above sensor resolution
    "viscous": {"b": 5.0},
    "stribeck": {"delta": 0.3, "v_s": 0.003},
    "pressure_friction": {"mu": 2e-6},
    "pressure_lag": {"delay": 0.03},
    "stiffness_drift": {"fraction": 0.1, "tau": 2.0},
    "rail_ripple": {"amplitude": 0.15, "wavelength": 0.003},
    "load_cell_drift": {"rate": 0.02},
}


def test_every_registered_effect_is_covered():
    assert set(STRONG) == set(EFFECTS)


@pytest.mark.parametrize("kind", sorted(STRONG))
def test_effect_changes_exactly_its_signals(kind, clean):
    effect = make_effect({"kind": kind, **STRONG[kind]})
    sim = _simulate([{"kind": kind, **STRONG[kind]}])
    for channel in ("P", "x", "F"):
        diff = np.abs(sim.log[channel] - clean.log[channel])
        lsb = getattr(SENSORS, channel).lsb
        if channel in effect.signals:
            # visibly: a sustained change of several ADC counts, not one flipped rounding
            assert np.percentile(diff, 95) >= 2 * lsb, f"{kind} barely changes {channel}"
        else:
            assert np.all(diff == 0.0), f"{kind} changed {channel}, which it must not"
    assert sim.truth["effects"] == [{"kind": kind, **effect.params()}]


def test_viscous_friction_adds_b_v_while_sliding():
    sim = _simulate([{"kind": "viscous", "b": 5.0}])
    tr = sim.trajectory
    sliding = ~tr.stuck & (np.abs(tr.v) > 5e-3)
    assert sliding.sum() > 1000
    expected = np.sign(tr.v) * 0.35 + 5.0 * tr.v
    # friction is evaluated at the velocity one substep (1/20 ms) before the logged v
    atol = 5.0 * np.abs(tr.a[sliding]) / (1000.0 * 20) + 1e-12
    np.testing.assert_array_less(np.abs(tr.friction[sliding] - expected[sliding]), atol * 1.01)


def test_stribeck_raises_breakaway_and_sticking(clean):
    sim = _simulate([{"kind": "stribeck", "delta": 0.3, "v_s": 0.003}])
    assert sim.trajectory.stuck.mean() > clean.trajectory.stuck.mean()
    tr = sim.trajectory
    fast = ~tr.stuck & (np.abs(tr.v) > 0.015)  # 5 v_s: the Stribeck excess has decayed
    assert fast.sum() > 1000
    np.testing.assert_allclose(np.abs(tr.friction[fast]), 0.35, atol=0.3 * np.exp(-25) + 1e-9)


def test_pressure_friction_scales_with_pressure():
    sim = _simulate([{"kind": "pressure_friction", "mu": 2e-6}])
    tr = sim.trajectory
    sliding = ~tr.stuck & (np.abs(tr.v) > 1e-3)
    assert sliding.sum() > 1000
    np.testing.assert_allclose(np.abs(tr.friction[sliding]), 0.35 + 2e-6 * tr.P[sliding], rtol=1e-9)


def test_pressure_lag_delays_the_measured_pressure(clean):
    sim = _simulate([{"kind": "pressure_lag", "delay": 0.03}])
    p_clean, p_lag = clean.log["P"], sim.log["P"]
    lags = np.arange(0, 80)
    err = [np.mean(np.abs(p_lag[k:] - p_clean[: len(p_clean) - k])) for k in lags]
    assert lags[int(np.argmin(err))] == 30  # samples at 1 kHz


def test_stiffness_drift_lengthens_the_muscle_at_equal_pressure(clean):
    sim = _simulate([{"kind": "stiffness_drift", "fraction": 0.1, "tau": 2.0}], duration=8.0)
    # Same command, softer latex later on: larger elongation at the late pressure peaks.
    late = sim.trajectory.t > 6.0
    ref = _simulate(duration=8.0)
    assert sim.trajectory.x[late].max() > ref.trajectory.x[late].max() + 5e-4


def test_load_cell_drift_is_an_offset_growing_in_time(clean):
    sim = _simulate([{"kind": "load_cell_drift", "rate": 0.02}])
    diff = sim.log["F"] - clean.log["F"]
    slope = np.polyfit(sim.log.t, diff, 1)[0]
    assert slope == pytest.approx(0.02, rel=0.05)


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ({"kind": "stribek"}, "unknown"),
        ({"kind": "viscous", "c": 1.0}, "unknown key 'c'"),
        ({"kind": "viscous", "b": -1.0}, "must be >= 0"),
        ({"kind": "viscous", "b": "x"}, "must be a number"),
        ({"b": 1.0}, "needs a 'kind'"),
    ],
)
def test_bad_effect_specs_are_config_errors(spec, match):
    with pytest.raises(ConfigError, match=match):
        make_effect(spec)
