"""Rig physics: stick-slip, friction law, force and energy balance, free fall, validity checks."""

import numpy as np
import pytest
from scipy.optimize import curve_fit

from hmid.errors import SimulationError
from hmid.simulate.params import FrictionParams, MuscleParams, RigParams, ValveParams
from hmid.simulate.profiles import Constant, Sine, Steps
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle, equilibrium

RATE = 1000.0
RIG = RigParams()
MASS = RIG.M + RIG.m1


def _time(duration):
    return np.arange(1, int(duration * RATE) + 1) / RATE


def test_block_below_breakaway_never_moves():
    # Start 0.8 breakaway forces away from equilibrium: the spring cannot overcome friction.
    P = 1.0e5
    x_eq = equilibrium(RIG, P)
    k_local = RIG.muscle.k1 + 3 * RIG.muscle.k3 * x_eq**2
    x0 = x_eq + 0.8 * RIG.friction.coulomb / k_local
    traj = integrate(HydroMuscle(RIG, x0=x0), {"P_cmd": np.full(2000, P)}, RATE)
    assert np.all(traj.x == x0)
    assert np.all(traj.v == 0.0)
    assert traj.stuck.all()


def test_block_stops_and_stays_stopped_inside_friction_band():
    # A step, then a long hold: the block rings, sticks, and stays exactly still. (k2 = 0: with
    # the Maxwell arm the muscle creeps and the block follows it, see the next test.)
    rig = RIG.model_copy(update={"muscle": MuscleParams(k2=0.0)})
    P_cmd = np.where(_time(4.0) < 0.5, 5.0e4, 1.0e5)
    traj = integrate(HydroMuscle(rig), {"P_cmd": P_cmd}, RATE)
    final = traj.t > 2.0
    assert traj.stuck[final].all()
    assert np.ptp(traj.x[final]) == 0.0
    m = rig.muscle
    x = traj.x[-1]
    spring = m.A_eff * traj.P[-1] + m.F0 - (m.k1 * x + m.k3 * x**3)
    assert abs(spring - rig.m1 * rig.g) <= rig.friction.coulomb + 1e-12


def test_creep_under_friction_follows_the_band_edge():
    # With the SLS arm the stuck block's holding force grows as q relaxes; with breakaway =
    # Coulomb it creeps so that |F_m - m1 g| stays at the friction level, moving one way only.
    P_cmd = np.where(_time(6.0) < 0.5, 5.0e4, 1.5e5)
    traj = integrate(HydroMuscle(RIG), {"P_cmd": P_cmd}, RATE)
    late = traj.t > 2.5  # the step's ringing has died out
    assert np.all(np.diff(traj.x[late]) >= 0)
    net = traj.F_m[late] - RIG.m1 * RIG.g
    np.testing.assert_allclose(np.abs(net), RIG.friction.coulomb, atol=1e-3)
    # Creep at constant holding force decays with the SLS retardation time tau (k + k2) / k,
    # k the spring's local stiffness: fit x(t) = x_inf - A exp(-t / tau_fit) to the tail.
    m = RIG.muscle
    k = m.k1 + 3 * m.k3 * traj.x[-1] ** 2
    tau_ret = m.tau * (k + m.k2) / k
    tail = traj.t > 2.5
    (_, _, tau_fit), _ = curve_fit(
        lambda t, x_inf, amp, tau: x_inf - amp * np.exp(-(t - 2.5) / tau),
        traj.t[tail], traj.x[tail], p0=(traj.x[-1], 1e-5, 0.3),
    )  # fmt: skip
    assert tau_fit == pytest.approx(tau_ret, rel=0.05)


def _constitutive(rig, traj):
    m = rig.muscle
    return m.A_eff * traj.P + m.F0 - (m.k1 * traj.x + m.k3 * traj.x**3 + traj.q)


@pytest.mark.parametrize("profile", [Sine(), Steps(levels=(5e4, 1e5, 1.5e5), hold=0.7)])
def test_load_cell_plus_friction_is_the_muscle_law_eq_4_1_4_2(profile):
    # What identification sees: F_l + f (eqs. 4.1, 4.2) against F_m = f(x, q, P) at the logged
    # state. The reading is evaluated at that state, so they agree to rounding: forces of the
    # last substep's start lagged the position by a substep, which the loop read as negative
    # damping of stiffness x 50 us (a Stribeck-like effect "found" in clean data).
    t = _time(3.0)
    P_cmd = profile.command(t, None)
    for substeps in (10, 40):
        traj = integrate(HydroMuscle(RIG), {"P_cmd": P_cmd}, RATE, substeps=substeps)
        load_cell = MASS * traj.a + RIG.m1 * RIG.g
        ok = ~traj.contact
        gap = load_cell[ok] + traj.friction[ok] - _constitutive(RIG, traj)[ok]
        assert np.sqrt(np.mean(gap**2)) < 1e-12


def _energy(rig, traj, P):
    m = rig.muscle
    spring = 0.5 * m.k1 * traj.x**2 + 0.25 * m.k3 * traj.x**4
    return 0.5 * MASS * traj.v**2 + spring - m.A_eff * P * traj.x + rig.m1 * rig.g * traj.x


def test_energy_is_conserved_without_losses():
    rig = RIG.model_copy(
        update={
            "muscle": MuscleParams(k2=0.0),
            "friction": FrictionParams(F_block=0.0, F_pulley=0.0),
        }
    )
    P = 1.2e5
    x0 = equilibrium(rig, P) + 1e-3
    traj = integrate(HydroMuscle(rig, x0=x0), {"P_cmd": np.full(3000, P)}, RATE, substeps=20)
    E = _energy(rig, traj, P)
    amplitude_energy = 0.5 * (rig.muscle.k1) * (1e-3) ** 2
    # Semi-implicit Euler conserves a shadow energy: the error stays O(omega dt) and bounded.
    assert np.ptp(E) < 0.02 * amplitude_energy


def test_coulomb_friction_dissipates_exactly_its_work():
    rig = RIG.model_copy(update={"muscle": MuscleParams(k2=0.0)})
    P = 1.2e5
    x0 = equilibrium(rig, P) + 1.2e-3
    traj = integrate(HydroMuscle(rig, x0=x0), {"P_cmd": np.full(2000, P)}, RATE, substeps=20)
    E = _energy(rig, traj, P)
    path = np.sum(np.abs(np.diff(np.r_[x0, traj.x])))
    E0 = _energy(rig, traj.replace(x=np.array([x0]), v=np.array([0.0])), P)[0]
    lost = E0 - E[-1]
    assert lost == pytest.approx(rig.friction.coulomb * path, rel=0.02)


def test_free_fall_acceleration_and_load_cell():
    t = _time(0.3)
    traj = integrate(
        HydroMuscle(RIG, connected=False, x0=0.15),
        {"P_cmd": np.zeros(len(t)), "held": t < 0.1},
        RATE,
    )
    sliding = (t > 0.102) & ~traj.contact
    assert sliding.sum() > 150
    expected = -(RIG.m1 * RIG.g - RIG.friction.coulomb) / MASS
    np.testing.assert_allclose(traj.a[sliding], expected, rtol=1e-9)
    load_cell = MASS * traj.a + RIG.m1 * RIG.g  # eq. 4.2 reads the friction while sliding
    np.testing.assert_allclose(load_cell[sliding], RIG.friction.coulomb, rtol=1e-6)
    assert np.all(traj.x[t < 0.1] == 0.15)


def test_static_breakaway_excess_holds_then_releases():
    # static_ratio > 1: a block at rest needs more than Coulomb to start.
    rig = RIG.model_copy(update={"friction": FrictionParams(static_ratio=2.0)})
    x_eq = equilibrium(rig, 1e5)
    k_local = rig.muscle.k1 + 3 * rig.muscle.k3 * x_eq**2
    held = integrate(
        HydroMuscle(rig, x0=x_eq + 1.5 * rig.friction.coulomb / k_local),
        {"P_cmd": np.full(500, 1e5)},
        RATE,
    )
    assert held.stuck.all()
    moves = integrate(
        HydroMuscle(rig, x0=x_eq + 2.5 * rig.friction.coulomb / k_local),
        {"P_cmd": np.full(500, 1e5)},
        RATE,
    )
    assert not moves.stuck.all()


def test_slack_string_is_an_error():
    violent = RIG.model_copy(update={"valve": ValveParams(tau=1e-3, slew=1e9)})
    P_cmd = np.where(_time(1.0) < 0.5, 8e5, 0.0)
    with pytest.raises(SimulationError, match="slack"):
        integrate(HydroMuscle(violent, x0=equilibrium(violent, 8e5)), {"P_cmd": P_cmd}, RATE)


def test_valve_slew_limits_pressure_rate():
    P_cmd = np.where(_time(1.0) < 0.2, 0.0, 3e5)
    traj = integrate(HydroMuscle(RIG), {"P_cmd": P_cmd}, RATE)
    assert np.max(np.diff(traj.P)) * RATE <= RIG.valve.slew * (1 + 1e-9)
    assert traj.P[-1] == pytest.approx(3e5, rel=1e-6)


def test_constant_profile_is_constant():
    assert np.all(Constant(value=7.0).command(_time(1.0), None) == 7.0)
