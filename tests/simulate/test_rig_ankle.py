"""The Ch. 6 ankle: its geometry is virtual work, it rests where the torques balance, it keeps
its energy but for the damping's work, its valves and effects act, and Ch. 6 follows."""

import math
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from pydantic import ValidationError

from hmid.errors import ConfigError
from hmid.simulate.ankle_ch6 import reproduce_ch6
from hmid.simulate.effects import make_effect
from hmid.simulate.rig import closed_loop, integrate
from hmid.simulate.rigs.ankle import Ankle, equilibrium, geometry, statics
from hmid.simulate.rigs.ankle_params import AnkleParams, load_ankle_params
from hmid.simulate.valves import OnOffValves, ProportionalValve

ROOT = Path(__file__).resolve().parents[2]
RATE = 1000.0
FRICTIONLESS = AnkleParams(coulomb=0.0)
MIXED = (4.0e5, 5.0e5, 3.0e5, 4.5e5, 6.0e5)  # a pressure set, a different one per fibre
DEG = math.pi / 180


def hold(n: int, params: AnkleParams = FRICTIONLESS) -> np.ndarray:
    """Valve commands that hold every fibre's pressure (on/off: both valves shut)."""
    return np.zeros((n, params.n_active))


@pytest.mark.parametrize("muscle", ["gastrocnemius", "soleus", "tibialis"])
def test_moment_arms_are_minus_the_derivative_of_fibre_length(muscle):
    group = AnkleParams().groups[muscle]
    theta = np.linspace(-25, 45, 141) * DEG
    h = 1e-6
    _, r = geometry(theta, *group.origin, *group.insertion, xp=np)
    L_up, _ = geometry(theta + h, *group.origin, *group.insertion, xp=np)
    L_down, _ = geometry(theta - h, *group.origin, *group.insertion, xp=np)
    np.testing.assert_allclose(r, -(L_up - L_down) / (2 * h), atol=1e-9)
    sign = -1 if muscle == "tibialis" else 1  # rear fibres plantarflex, the front one dorsiflexes
    assert np.all(sign * r > 0.015)


def test_the_heel_lever_is_the_thesis_derived_arm_at_full_force():
    s = statics(AnkleParams(), -20 * DEG, 0.0)
    assert s["r"][:5] == pytest.approx(0.065, abs=0.001)


def test_the_foot_rests_where_the_torques_balance():
    theta = equilibrium(FRICTIONLESS, MIXED, hung_mass=5.0)
    lo, hi = FRICTIONLESS.theta_range
    assert lo + 5 * DEG < theta < hi - 5 * DEG  # an interior rest, not an end stop
    assert statics(FRICTIONLESS, theta, MIXED, 5.0)["net"] == pytest.approx(0.0, abs=1e-9)
    rig = Ankle(FRICTIONLESS, P0=MIXED, theta0=theta)
    traj = integrate(rig, {"valves": hold(2000), "hung_mass": np.full(2000, 5.0)}, RATE)
    np.testing.assert_allclose(traj.P, np.tile(MIXED, (2000, 1)), atol=1e-6)
    assert np.max(np.abs(traj.theta - theta)) < 1e-9
    # the fibres' torque balances the weights: foot and hung mass
    hx, hy = FRICTIONLESS.hook
    cx, cy = FRICTIONLESS.foot_com
    weight = FRICTIONLESS.g * (FRICTIONLESS.foot_mass * (cx * np.cos(theta) + cy * np.sin(theta))
                               + 5.0 * (hx * np.cos(theta) + hy * np.sin(theta)))  # fmt: skip
    assert traj.torque[-1] == pytest.approx(-weight, abs=1e-9)


def test_a_displaced_foot_settles_on_the_equilibrium():
    theta = equilibrium(FRICTIONLESS, MIXED, hung_mass=5.0)
    rig = Ankle(FRICTIONLESS, P0=MIXED, theta0=theta + 8 * DEG)
    traj = integrate(rig, {"valves": hold(8000), "hung_mass": np.full(8000, 5.0)}, RATE)
    assert traj.theta[-1] == pytest.approx(theta, abs=1e-5)


def test_every_rear_fibre_vented_rests_in_full_plantarflexion_filled_in_full_dorsiflexion():
    params = AnkleParams()
    assert equilibrium(params, 0.0) == pytest.approx(40 * DEG)
    assert equilibrium(params, params.supply) == pytest.approx(-20 * DEG)


@pytest.mark.parametrize("damping", [0.0, 0.3])
def test_energy_is_kept_but_for_the_dampings_work(damping):
    """Passive plant (pressures held, no friction, no Maxwell arm): kinetic + potential energy
    changes by exactly minus the damping's work, int c omega^2 dt."""
    base = AnkleParams(coulomb=0.0, damping=damping)
    fibres = tuple(m.model_copy(update={"k2": 0.0}) for m in base.muscles())
    params = base.model_copy(update={"fibres": fibres})
    theta_eq = equilibrium(params, MIXED)
    rig = Ankle(params, P0=MIXED, theta0=theta_eq + 10 * DEG)
    n, rate = 3000, 10000.0
    traj = integrate(rig, {"valves": hold(n, params)}, rate, substeps=4)
    assert np.all(traj.contact == 0)  # no end stop touched: the energy stays mechanical
    # potential: minus the integral of the net torque (fibres + weight) over the angle
    grid = np.linspace(traj.theta.min() - 0.01, traj.theta.max() + 0.01, 801)
    net = np.array([statics(params, th, MIXED)["net"] for th in grid])
    V = -np.concatenate([[0.0], np.cumsum(0.5 * (net[1:] + net[:-1]) * np.diff(grid))])
    energy = 0.5 * params.foot_inertia * traj.omega**2 + np.interp(traj.theta, grid, V)
    power = damping * traj.omega**2
    work = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(traj.t) * (power[1:] + power[:-1]))])
    swing = 0.5 * params.foot_inertia * np.max(traj.omega**2)  # the energy in play
    assert swing > 0.1  # J: the foot does swing
    np.testing.assert_allclose(energy + work, energy[0], atol=5e-3 * swing)
    if damping:
        assert work[-1] > 0.5 * swing  # the damping took most of it


def test_valves_fill_and_vent_each_fibre_on_its_own():
    n = 1500
    commands = np.zeros((n, 5))
    commands[:, 0] = 1.0  # gastrocnemius 1 fills
    commands[:, 2] = -1.0  # soleus 1 vents
    rig = Ankle(P0=(0.0, 0.0, 3e5, 3e5, 3e5))
    traj = integrate(rig, {"valves": commands}, RATE)
    assert traj.P[-1, 0] == pytest.approx(6e5, rel=1e-3)
    assert traj.P[-1, 2] == pytest.approx(0.0, abs=1e3)
    assert traj.P[-1, 3] == traj.P[0, 3] == 3e5  # held


def test_a_proportional_valve_sets_the_pressure_it_is_told():
    params = AnkleParams(valve=ProportionalValve())
    traj = integrate(Ankle(params), {"valves": np.full((2000, 5), 2.5e5)}, RATE)
    np.testing.assert_allclose(traj.P[-1], 2.5e5)
    assert traj.theta[-1] == pytest.approx(equilibrium(params, 2.5e5), abs=1e-4)


def test_the_potentiometer_reads_on_its_grid():
    traj = integrate(Ankle(), {"valves": np.ones((800, 5))}, RATE)
    lsb = AnkleParams().potentiometer.lsb
    np.testing.assert_allclose(traj.theta_pot / lsb, np.round(traj.theta_pot / lsb), atol=1e-9)
    assert np.max(np.abs(traj.theta_pot - traj.theta)) <= lsb / 2 + 1e-12


def test_undeclared_effects_change_the_plant():
    n = 3000
    hung = np.where(np.arange(n) >= 500, 9.1, 0.0)  # hung at 0.5 s
    inputs = {"valves": hold(n, AnkleParams()), "hung_mass": hung}
    P0 = (0.0, 0.0, 6e5, 6e5, 6e5)
    plain = integrate(Ankle(P0=P0), inputs, RATE)
    drift = make_effect({"kind": "stiffness_drift", "fraction": 0.2, "tau": 1.0})
    softer = integrate(Ankle(effects=(drift,), P0=P0), inputs, RATE)
    assert softer.theta[-1] < plain.theta[-1] - 1 * DEG  # a softer latex gives way more
    rubbing = integrate(Ankle(effects=(make_effect({"kind": "viscous", "b": 2.0}),), P0=P0),
                        inputs, RATE)  # fmt: skip
    assert np.max(np.abs(rubbing.omega)) < np.max(np.abs(plain.omega))


class PassThrough(eqx.Module):
    def init(self):
        return jnp.zeros(())

    def step(self, state, measured, reference):
        return state, {"valves": reference}


def test_a_controller_sets_the_valves_inside_the_scan():
    n = 1200
    commands = np.where(np.arange(n) < 600, 1.0, -1.0)[:, None] * np.ones(5)
    rig = Ankle()
    inputs = {"valves": commands}
    open_ = integrate(rig, inputs, RATE)
    closed, given = closed_loop(rig, PassThrough(), commands, RATE, initial_inputs=inputs,
                                initial_outputs=rig.initial_outputs(inputs))  # fmt: skip
    np.testing.assert_array_equal(given["valves"], commands)
    np.testing.assert_allclose(closed.theta, open_.theta, atol=1e-12)


def test_bad_inputs_and_params_are_errors():
    with pytest.raises(ValueError, match="one column per active fibre"):
        integrate(Ankle(), {"valves": np.zeros(10)}, RATE)
    with pytest.raises(ValidationError, match="must equal supply"):
        AnkleParams(valve=OnOffValves(supply=5e5))
    with pytest.raises(ValidationError, match="the ankle has 8"):
        AnkleParams(fibres=AnkleParams().muscles()[:5])


def test_the_shipped_plant_config_is_the_default_plant(tmp_path):
    assert load_ankle_params(ROOT / "configs/control/ankle-plant.yaml") == AnkleParams()
    bad = tmp_path / "plant.yaml"
    bad.write_text("foot_mas: 1.0\n")
    with pytest.raises(ConfigError, match="key 'foot_mas'"):
        load_ankle_params(bad)


@pytest.mark.slow  # the five Ch. 6 experiments: ~10 s
def test_chapter_6_follows_within_its_tolerances():
    result = reproduce_ch6()
    table = result.table.frame()
    assert result.table.all_within, table[~table.within].to_string()
    follows = set(table.quantity[table.status == "follows"])
    assert {"ankle torque at full force", "torque per body mass (62 kg)",
            "stiffness ordering (superset stiffer)", "one more soleus relaxed",
            "travel time ratio, slower / faster direction"} <= follows  # fmt: skip
    assert len(result.stiffness) == 11  # (0-2 gastrocnemius) x (0-3 soleus), none empty
