"""Each extra effect changes the signals it should, visibly, and nothing else; and its physics."""

import numpy as np
import pytest

from hmid.errors import ConfigError
from hmid.simulate.effects import EFFECTS, make_effect
from hmid.simulate.params import RigParams, Sensors, SensorSpec
from hmid.simulate.profiles import Sine
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle, equilibrium
from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, FreeFallLog, HydroMuscleDataset

SENSORS = Sensors()
PROFILE = Sine(offset=1.4e5, amplitude=1.0e5, frequency=0.5)
RIG = RigParams()
DT_SUB = 1.0 / (1000.0 * 20)  # the data set's substep: 1 kHz, 20 substeps


def _simulate(effects=(), duration=6.0, seed=3, sensors=None):
    spec = DynamicLog(
        name="e", duration=duration, profile=PROFILE, effects=tuple(effects), sensors=sensors
    )
    return HydroMuscleDataset(seed=seed, logs=(spec,)).simulate(spec)


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
    "position_friction": {"slope": 30.0, "x_ref": 0.007},
    "direction_viscous": {"b_pos": 6.0, "b_neg": 2.0},
    "position_sensor_delay": {"delay": 0.016, "hold": 0.0165},
    "muscle_damping": {"c": 6.0},
}


def test_every_registered_effect_is_covered():
    assert set(STRONG) == set(EFFECTS)


@pytest.mark.parametrize("kind", sorted(EFFECTS))
def test_every_registered_effect_builds_from_defaults_and_keeps_to_its_signals(kind, clean):
    effect = EFFECTS[kind]()
    assert effect.kind == kind
    assert set(effect.signals) and set(effect.signals) <= {"P", "x", "F"}
    params = effect.params()
    assert make_effect({"kind": kind, **params}).params() == params  # the truth record rebuilds it
    sim = _simulate([{"kind": kind}])
    changed = {ch for ch in ("P", "x", "F") if np.any(sim.log[ch] != clean.log[ch])}
    assert changed == set(effect.signals), f"{kind} changed {sorted(changed)}"


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


def _sliding(tr, speed):
    sliding = ~tr.stuck & ~tr.contact & (np.abs(tr.v) > speed)
    assert sliding.sum() > 1000
    return sliding


@pytest.mark.parametrize("span", [0.0, 0.002])
def test_position_friction_adds_slope_times_distance_from_x_ref(span):
    slope, x_ref = 30.0, 0.007
    spec = {"kind": "position_friction", "slope": slope, "x_ref": x_ref, "span": span}
    tr = _simulate([spec]).trajectory
    sliding = _sliding(tr, 1e-3)
    assert np.ptp(tr.x[sliding]) > 8e-3  # the travel spans both sides of x_ref
    extra = tr.friction - np.sign(tr.v) * RIG.friction.coulomb
    offset = tr.x - x_ref if not span else np.clip(tr.x - x_ref, -span, span)
    expected = slope * offset * np.sign(tr.v)
    # friction is evaluated at the position one substep before the logged x
    atol = abs(slope) * np.abs(tr.v[sliding]) * DT_SUB + 1e-12
    np.testing.assert_array_less(np.abs(extra[sliding] - expected[sliding]), atol * 1.01)


@pytest.mark.parametrize(
    ("offset", "slope", "moves"),
    [(1.5, 0.0, True), (1.5, 60.0, False), (0.8, 0.0, False), (0.8, -60.0, True)],
)
def test_position_friction_raises_or_lowers_the_breakaway_level(offset, slope, moves):
    # Start `offset` Coulomb levels of spring force from equilibrium, near x = 5 mm: a slope of
    # +-60 N/m adds +-0.3 N (0.86 Fc) to the level that holds the block there.
    P = 1.0e5
    x_eq = equilibrium(RIG, P)
    k_local = RIG.muscle.k1 + 3 * RIG.muscle.k3 * x_eq**2
    x0 = x_eq + offset * RIG.friction.coulomb / k_local
    effects = (make_effect({"kind": "position_friction", "slope": slope}),)
    traj = integrate(HydroMuscle(RIG, effects=effects, x0=x0), {"P_cmd": np.full(500, P)}, 1000.0)
    assert traj.stuck.all() != moves


def test_direction_viscous_has_one_coefficient_per_direction():
    b_pos, b_neg = 6.0, 2.0
    tr = _simulate([{"kind": "direction_viscous", "b_pos": b_pos, "b_neg": b_neg}]).trajectory
    sliding = _sliding(tr, 5e-3)
    assert (tr.v[sliding] > 0).sum() > 500 and (tr.v[sliding] < 0).sum() > 500
    b = np.where(tr.v > 0, b_pos, b_neg)
    expected = np.sign(tr.v) * RIG.friction.coulomb + b * tr.v
    # friction is evaluated at the velocity one substep before the logged v
    atol = b[sliding] * np.abs(tr.a[sliding]) * DT_SUB + 1e-12
    np.testing.assert_array_less(np.abs(tr.friction[sliding] - expected[sliding]), atol * 1.01)


@pytest.mark.parametrize("hold", [0.0165, 0.0])
def test_position_sensor_delay_reports_the_true_x_delayed_and_held(hold):
    delay = 0.016
    quiet = Sensors(x=SensorSpec(lo=0.0, hi=0.02048, noise=0.0))
    effect = {"kind": "position_sensor_delay", "delay": delay, "hold": hold}
    sim = _simulate([effect], sensors=quiet)
    tr = sim.trajectory
    # in whole microseconds: the hold instant k hold <= t - delay, exactly
    t_us = np.rint(tr.t * 1e6).astype(np.int64)
    due = t_us - round(delay * 1e6)
    if hold:
        due = (due // round(hold * 1e6)) * round(hold * 1e6)
    expected = np.interp(due * 1e-6, tr.t, tr.x)  # before the first sample: the first value
    np.testing.assert_array_less(np.abs(sim.log["x"] - expected), 0.5 * quiet.x.lsb + 1e-12)
    assert np.all(sim.log["x"][tr.t < tr.t[0] + delay] == sim.log["x"][0])
    if hold:  # steps: the reading changes at most once per hold period
        assert np.count_nonzero(np.diff(sim.log["x"])) <= tr.t[-1] / hold + 1


def test_muscle_damping_adds_minus_c_v_to_the_muscle_force():
    c = 6.0
    tr = _simulate([{"kind": "muscle_damping", "c": c}]).trajectory
    m = RIG.muscle
    springs = m.A_eff * tr.P + m.F0 - (m.k1 * tr.x + m.k3 * tr.x**3 + tr.q)
    moving = _sliding(tr, 1e-3)
    # F_m comes from the state one substep before the logged one: the springs' and the
    # dashpot's change over that substep (dq/dt = k2 v - q / tau) bound the gap
    dq = np.abs(m.k2 * tr.v - tr.q / m.tau)
    bound = ((m.k1 + 3 * m.k3 * tr.x**2) * np.abs(tr.v) + dq + c * np.abs(tr.a)) * DT_SUB
    gap = tr.F_m - springs + c * tr.v
    np.testing.assert_array_less(np.abs(gap[moving]), 1.05 * bound[moving] + 1e-12)
    assert np.median(np.abs(c * tr.v[moving])) > 10 * np.median(bound[moving])  # resolved


def test_muscle_damping_needs_the_muscle_free_falls_do_not_show_it():
    def fall(effects):
        spec = FreeFallLog(name="ff", duration=0.3, effects=tuple(effects))
        return HydroMuscleDataset(seed=5, logs=(spec,)).simulate(spec)

    clean, damped = fall(()), fall([{"kind": "muscle_damping", "c": 6.0}])
    assert clean.log.data.equals(damped.log.data)
    viscous = fall([{"kind": "viscous", "b": 6.0}])  # rail friction does show
    assert not clean.log.data.equals(viscous.log.data)


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ({"kind": "stribek"}, "unknown"),
        ({"kind": "viscous", "c": 1.0}, "unknown key 'c'"),
        ({"kind": "viscous", "b": -1.0}, "must be >= 0"),
        ({"kind": "viscous", "b": "x"}, "must be a number"),
        ({"b": 1.0}, "needs a 'kind'"),
        ({"kind": "position_friction", "slope": float("nan")}, "slope=nan must be finite"),
        ({"kind": "direction_viscous", "b_pos": -1.0}, "b_pos=-1.0 must be >= 0"),
        ({"kind": "direction_viscous", "b_neg": -0.5}, "b_neg=-0.5 must be >= 0"),
        ({"kind": "position_sensor_delay", "delay": -0.01}, "delay=-0.01 must be >= 0"),
        ({"kind": "position_sensor_delay", "hold": -0.001}, "hold=-0.001 must be >= 0"),
        ({"kind": "muscle_damping", "c": -2.0}, "c=-2.0 must be >= 0"),
    ],
)
def test_bad_effect_specs_are_config_errors(spec, match):
    with pytest.raises(ConfigError, match=match) as error:
        make_effect(spec)
    assert "\n" not in str(error.value)
