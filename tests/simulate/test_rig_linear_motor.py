"""Positioning-stage physics: force balance, stick-slip, pure mass, energy, effects, reference."""

import numpy as np
import pytest
from scipy.signal import periodogram

from hmid.simulate.reference import RandomReference
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.linear_motor import (
    LinearMotor,
    LinearMotorParams,
    PDController,
    balance_residual,
)

RATE = 1000.0
DT = 1.0 / RATE
STEP = 1e-6
STAGE = LinearMotorParams()
FS = STAGE.Fc * STAGE.static_ratio


def _reference(duration=15.0, seed=3, **kw):
    return RandomReference(**kw).positions(
        round(duration * RATE), RATE, np.random.default_rng(seed)
    )


def _closed_loop(stage=STAGE, substeps=20, **kw):
    rig = LinearMotor(stage, PDController(), encoder_step=STEP)
    return integrate(rig, {"r": _reference(**kw)}, RATE, substeps=substeps)


def _open_loop(force, stage=STAGE):
    force = np.asarray(force, dtype=float)
    rig = LinearMotor(stage, None, encoder_step=STEP)
    return integrate(rig, {"r": np.zeros(len(force)), "feedforward": force}, RATE)


def test_logged_force_balances_the_true_motion_on_sliding_samples():
    # The logged force (the mean applied over t_k +- dt/2) against M a + Fv v + Fc sign(v) +
    # offset, a the mean acceleration over t_k +- dt. What is left is viscous friction on the
    # gap between v(t_k) and the velocity the integrator used: v is piecewise linear with a kink
    # at t_k (gap (a+ - a-) dt / 4) and each substep uses its starting velocity (a dt_sub / 2).
    # Logging u[k] instead of the interval mean would leave M (a+ - a-) / 2, several newtons.
    traj = _closed_loop()
    sliding = traj.sliding
    assert sliding.mean() > 0.95
    residual = balance_residual(STAGE, traj)[sliding]
    jump = np.abs(np.diff(traj.u, prepend=0.0)) / STAGE.M
    bound = STAGE.Fv * (jump * DT / 4 + np.abs(traj.a) * DT / 20 / 2)
    assert np.all(np.abs(residual) <= 1.2 * bound[sliding] + 1e-9)
    assert np.sqrt(np.mean(residual**2)) < 1e-3 * STAGE.Fc


def test_sanity_least_squares_recovers_the_law_from_the_true_motion():
    traj = _closed_loop()
    s = traj.sliding
    design = np.column_stack([traj.a[s], traj.v[s], np.sign(traj.v[s]), np.ones(s.sum())])
    (M, Fv, Fc, offset), *_ = np.linalg.lstsq(design, traj.u_mean[s], rcond=None)
    truth = (STAGE.M, STAGE.Fv, STAGE.Fc, STAGE.offset)
    np.testing.assert_allclose((M, Fv, Fc, offset), truth, rtol=5e-3)


def test_stage_sticks_at_reversals_and_stays_exactly_still_while_below_breakaway():
    traj = _closed_loop(rms=0.01, cutoff_hz=1.0)
    stuck = traj.stuck[:-1]
    holds = stuck & (np.abs(traj.u[:-1] - STAGE.offset) <= FS)
    assert holds.sum() > 100  # a slow reference: the stage sticks at most reversals
    assert np.all(traj.x[1:][holds] == traj.x[:-1][holds])
    assert np.all(traj.stuck[1:][holds])
    breaks = stuck & ~holds
    assert breaks.sum() > 5 and np.all(traj.x[1:][breaks] != traj.x[:-1][breaks])
    assert 0.005 < traj.stuck.mean() < 0.1  # sticks sometimes, slides most of the time


@pytest.mark.parametrize("static_ratio", [1.0, 2.0])
def test_open_loop_breakaway_threshold(static_ratio):
    stage = LinearMotorParams(static_ratio=static_ratio)
    Fs = stage.Fc * static_ratio
    for sign in (1.0, -1.0):
        held = _open_loop(np.full(500, stage.offset + sign * 0.99 * Fs), stage)
        assert np.all(held.x == 0.0) and np.all(held.v == 0.0) and held.stuck.all()
        moves = _open_loop(np.full(500, stage.offset + sign * 1.01 * Fs), stage)
        assert np.sign(moves.x[-1]) == sign and not moves.stuck[1:].any()
        # once sliding, the Coulomb level (not the breakaway level) opposes the motion
        F_app = 1.01 * Fs
        expected = (F_app - stage.Fc) / stage.M
        assert sign * moves.a[2] == pytest.approx(expected, rel=0.01)


def test_stage_stops_without_chattering_and_reverses_through_one_stop():
    # Push, then hold half the Coulomb level: it decelerates, stops, stays stopped.
    push = np.where(np.arange(1500) < 300, 100.0, STAGE.offset + 0.5 * STAGE.Fc)
    traj = _open_loop(push)
    stop = np.argmax(traj.stuck[300:]) + 300
    assert stop > 300 and traj.stuck[stop:].all()
    assert np.all(traj.v[stop:] == 0.0) and np.ptp(traj.x[stop:]) == 0.0
    assert np.all(traj.v >= 0.0)
    # Push, then pull hard: it reverses at once, one sign change, never read as stuck.
    pull = np.where(np.arange(1500) < 300, 100.0, -100.0)
    traj = _open_loop(pull)
    moving = np.sign(traj.v[1:])
    assert np.sum(moving[1:] != moving[:-1]) == 1
    assert not traj.stuck[1:].any()


def test_without_friction_the_stage_is_a_pure_mass():
    stage = LinearMotorParams(Fv=0.0, Fc=0.0)
    traj = _closed_loop(stage)
    # M dv / dt = u - offset exactly over each held sample
    M_a = stage.M * np.diff(traj.v) / DT
    np.testing.assert_allclose(M_a, traj.u[:-1] - stage.offset, rtol=0, atol=1e-9)
    # the trapezoid in x is exact for a constant force: x advances by v dt + a dt^2 / 2
    a = np.diff(traj.v) / DT
    dx = traj.v[:-1] * DT + a * DT**2 / 2
    np.testing.assert_allclose(np.diff(traj.x), dx, rtol=0, atol=1e-14)


def test_energy_balance_work_in_equals_dissipation_plus_kinetic_energy():
    # Work of the held force, W = sum (u[k] - offset) dx_k, against viscous loss, Coulomb loss
    # Fc * path, and the final kinetic energy. The integrator is the trapezoid in x and in the
    # viscous force, which conserves energy; what remains is the O(dt^2) error of summing the
    # viscous loss Fv v^2 at the samples (trapezoid rule): |error| <= Fv dt^2 / 6 * integral
    # (a^2 + |v a'|) dt, 0.002 J here against a 0.0012 J imbalance (semi-implicit Euler, which
    # runs x half a substep ahead of the forces, gained M dt_sub / 2 * integral a^2 dt = 0.09 J).
    traj = _closed_loop()
    dx = np.diff(traj.x)
    work = np.sum((traj.u[:-1] - STAGE.offset) * dx)
    viscous = STAGE.Fv * np.sum(0.5 * (traj.v[:-1] ** 2 + traj.v[1:] ** 2)) * DT
    coulomb = STAGE.Fc * np.sum(np.abs(dx))
    kinetic = 0.5 * STAGE.M * (traj.v[-1] ** 2 - traj.v[0] ** 2)
    jerk = np.gradient(traj.a, DT)
    bound = STAGE.Fv * DT**2 / 6 * np.sum(traj.a**2 + np.abs(traj.v * jerk)) * DT
    assert coulomb > 0.2 * work and viscous > 0.2 * work  # both losses matter
    assert abs(work - viscous - coulomb - kinetic) < bound < 1e-4 * work


def test_direction_dependent_viscous_friction():
    stage = LinearMotorParams(Fv_negative=320.0)
    traj = _closed_loop(stage)
    s = traj.sliding
    net = traj.u_mean - stage.M * traj.a - stage.Fc * np.sign(traj.v) - stage.offset
    for side, Fv in ((traj.v > 0, stage.Fv), (traj.v < 0, 320.0)):
        pick = s & side
        assert np.sum(net[pick] * traj.v[pick]) / np.sum(traj.v[pick] ** 2) == pytest.approx(
            Fv, rel=5e-3
        )
    assert stage.effects() == [
        {"kind": "direction_viscous", "Fv_positive": 200.0, "Fv_negative": 320.0}
    ]
    assert LinearMotorParams(Fv_negative=200.0).effects() == []  # the same coefficient: no effect


def test_position_dependent_coulomb_friction():
    stage = LinearMotorParams(Fc_slope=300.0, x_centre=0.01)
    traj = _closed_loop(stage)
    s = traj.sliding
    assert np.ptp(traj.x) > 0.05  # Fc varies by more than 15 N across the log
    net = traj.u_mean - stage.M * traj.a - stage.Fv * traj.v - stage.offset
    design = np.column_stack([np.sign(traj.v), np.sign(traj.v) * (traj.x - 0.01)])[s]
    (Fc, slope), *_ = np.linalg.lstsq(design, net[s], rcond=None)
    assert Fc == pytest.approx(stage.Fc, rel=5e-3) and slope == pytest.approx(300.0, rel=5e-3)
    assert np.sqrt(np.mean(balance_residual(stage, traj)[s] ** 2)) < 1e-3 * stage.Fc
    # the level is clipped at zero far from the centre, and sets the breakaway level too
    np.testing.assert_allclose(stage.coulomb(np.array([-1.0, 0.01, 0.11])), [0.0, 20.0, 50.0])
    held = _open_loop(np.full(300, stage.offset + 0.99 * stage.coulomb(0.0)), stage)
    assert held.stuck.all()


def test_reference_is_band_limited_starts_at_rest_and_has_the_rms():
    for cutoff in (1.0, 2.0, 3.0):
        r = _reference(duration=20.0, cutoff_hz=cutoff, rms=0.015)
        f, power = periodogram(r, fs=RATE, window="hann")
        # a double-pass order-4 Butterworth leaves ~5e-9 of the power above 3 cutoffs; a
        # single pass would leave ~6e-5
        assert power[f > 3 * cutoff].sum() < 1e-6 * power.sum()
        assert np.sqrt(np.mean(r**2)) == pytest.approx(0.015, rel=1e-12)
        assert r[0] == 0.0 and abs(r[1]) < 1e-6  # zero value and slope at the start


def test_encoder_reading_is_rounded_position():
    traj = _closed_loop()
    counts = traj.x_meas / STEP
    assert np.max(np.abs(counts - np.round(counts))) < 1e-6  # whole steps, up to float division
    assert np.max(np.abs(traj.x_meas - traj.x)) <= 0.5 * STEP * (1 + 1e-9)


def test_unstable_gains_are_a_simulation_error():
    from hmid.errors import SimulationError

    wild = PDController(Kp=1e9, Kd=1e6)
    with pytest.raises(SimulationError, match="unstable"):
        integrate(
            LinearMotor(STAGE, wild, encoder_step=STEP), {"r": _reference(duration=2.0)}, RATE
        )
