"""Friction: recovered against simulator truth (Fc = F_block + F_pulley = 0.35 N), and one-line
errors that name the log. (How the friction enters a balance: tests/balance/test_prepare.py.)"""

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from hmid.errors import ConfigError, LogError
from hmid.friction import (
    Coulomb,
    CoulombViscous,
    FallRig,
    derivative_reach,
    identify_friction,
    plot_free_fall,
    sliding_segment,
)
from hmid.friction._models import _phi
from hmid.io.log import Log
from hmid.signal import MovingAverage, SavitzkyGolay, SmoothedFiniteDifference, Window
from hmid.simulate.rigs.hydro_muscle_dataset import FreeFallLog, HydroMuscleDataset

DIFF = SavitzkyGolay(Window(seconds=0.051), polyorder=3)
FC_TRUE = 0.35  # N, simulator default F_block + F_pulley
MASS, WEIGHT = 0.75, 0.5 * 9.80665
RIG = FallRig(MASS, WEIGHT)  # M + m1 dragged by m1 g


def _free_fall(seed: int, **kw):
    spec = FreeFallLog(name=f"ff-{seed}", seed=seed, **kw)
    return HydroMuscleDataset(seed=0, logs=(spec,)).simulate(spec)


def _inside(ci, value) -> bool:
    return ci[0] <= value <= ci[1]


@pytest.fixture(scope="module")
def demo_falls():
    """Like data/demo: 0.3 s logs released at 0.1 s from x0 = 0.15, 0.16, 0.17 m."""
    return [_free_fall(s, duration=0.3, x0=x0) for s, x0 in ((1, 0.15), (2, 0.16), (3, 0.17))]


# -- models -------------------------------------------------------------------------------------
def test_models_name_units_and_signed_friction():
    v = np.array([-0.1, 0.0, 0.2])
    assert Coulomb().units == {"Fc": "N"} and Coulomb().param_names == ("Fc",)
    assert CoulombViscous().units == {"Fc": "N", "b": "N s/m"}
    np.testing.assert_allclose(Coulomb().friction(v, {"Fc": 0.3}), [-0.3, 0.0, 0.3])
    np.testing.assert_allclose(
        CoulombViscous().friction(v, {"Fc": 0.3, "b": 2.0}), [-0.5, 0.0, 0.7]
    )


def test_phi_series_and_closed_forms_agree_and_derivatives_are_right():
    z = np.array([-0.3, -0.1 - 1e-9, -0.1 + 1e-9, -1e-3, 0.0, 0.05, 0.1 - 1e-9, 0.1 + 1e-9, 2.0])
    p1, p2, d1, d2 = _phi(z)
    zs = np.where(z == 0, 1.0, z)
    np.testing.assert_allclose(p1, np.where(z == 0, 1.0, -np.expm1(-zs) / zs), rtol=1e-12)
    np.testing.assert_allclose(np.diff(p2[1:3]), 0.0, atol=1e-9)  # continuous at the switch
    h = 1e-6
    np.testing.assert_allclose(d1, (_phi(z + h)[0] - _phi(z - h)[0]) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(d2, (_phi(z + h)[1] - _phi(z - h)[1]) / (2 * h), atol=1e-8)


def test_viscous_travel_solves_the_equation_of_motion():
    params = {"Fc": 0.35, "b": 5.0}
    tau = np.linspace(-0.1, 0.15, 26)
    rhs = lambda _, y: [y[1], (WEIGHT - params["Fc"] - params["b"] * y[1]) / MASS]  # noqa: E731
    ode = solve_ivp(rhs, (0, 0.15), [0.02, 0.4], t_eval=tau[tau >= 0], rtol=1e-11, atol=1e-13)
    closed = CoulombViscous().travel(tau[tau >= 0], 0.02, 0.4, params, RIG)
    np.testing.assert_allclose(closed, ode.y[0], atol=1e-10)


# -- simulator conventions the identification relies on -----------------------------------------
def test_simulated_free_fall_slides_toward_minus_x_at_the_coulomb_deceleration():
    sim = _free_fall(1, duration=0.3)
    traj, sliding = sim.trajectory, ~sim.trajectory.stuck
    assert sim.truth["friction_truth"]["coulomb_N"] == FC_TRUE
    assert np.all(traj.v[sliding] < 0)
    np.testing.assert_allclose(traj.a[sliding], -(WEIGHT - FC_TRUE) / MASS, rtol=1e-12)
    np.testing.assert_allclose(traj.friction[sliding], -FC_TRUE)  # sign(v) Fc


# -- Coulomb identification ---------------------------------------------------------------------
def test_coulomb_from_demo_like_falls_contains_the_truth(demo_falls):
    est = identify_friction([s.log for s in demo_falls], RIG, Coulomb(), differentiator=DIFF)
    assert est.model_name == "coulomb" and est.units == {"Fc": "N"}
    for r in est.per_log:
        assert _inside(r.ci["Fc"], FC_TRUE), r
        assert _inside(r.load_cell.ci["Fc"], FC_TRUE), r
        # x noise 0.1 mm and 0.2 mm steps: RMS sqrt(0.1^2 + 0.2^2/12) = 0.115 mm, white (DW ~ 2)
        assert 0.09e-3 < r.rmse_m < 0.14e-3 and r.r2 > 0.9999 and 1.4 < r.durbin_watson < 2.6
        # 200 samples slide; 25 (the SG half-window) are trimmed after the release
        assert r.n_samples == pytest.approx(175, abs=3) and r.t_start >= 0.1
        assert r.direction == -1
    assert _inside(est.ci["Fc"], FC_TRUE)
    # per log SE(Fc) = (M + m1) SE(a) ~ 0.0057 N; pooled over three, 95 % width ~ 0.013 N
    assert np.diff(est.ci["Fc"])[0] < 0.02
    assert est.q_dof == 2 and est.q_p > 0.01


def test_a_wrong_free_fall_mass_gives_a_finding_not_a_friction_level(demo_falls):
    logs = [s.log for s in demo_falls]
    right = identify_friction(logs, RIG, Coulomb(), differentiator=DIFF)
    assert right.impossible() == ()
    wrong = identify_friction(logs, FallRig(10 * MASS, WEIGHT), Coulomb(), differentiator=DIFF)
    (finding,) = wrong.impossible()  # 7.5 kg instead of 0.75: Fc < 0, whatever its interval
    assert finding.startswith("free-fall friction Fc = -") and "mass (7.5 kg)" in finding


def test_coulomb_interval_coverage_over_seeds():
    """Measured here: 55/60 = 91.7 % (seeds 100-119 alone: 17/20); 95 % over 2700 other logs."""
    logs = [_free_fall(100 + s, duration=0.3, x0=0.15).log for s in range(60)]
    est = identify_friction(logs, RIG, Coulomb(), differentiator=DIFF)
    covered = np.mean([_inside(r.ci["Fc"], FC_TRUE) for r in est.per_log])
    assert covered >= 0.85
    z = np.array([(r.params["Fc"] - FC_TRUE) / r.se["Fc"] for r in est.per_log])
    assert 0.7 < z.std() < 1.4  # honest standard errors: 1.16 here, 1.016 over 1500 logs
    # pooled over 60 logs: +-0.0015 N, 0.39 SE from the truth here; Q p = 0.03 (z std 1.16)
    assert _inside(est.ci["Fc"], FC_TRUE) and est.q_p > 0.001


def test_motion_toward_plus_x_gives_the_same_friction(demo_falls):
    log = demo_falls[0].log
    mirrored = Log(pd.DataFrame({"t": log.t, "x": -log["x"], "F": -log["F"]}), "mirrored")
    a, b = (
        identify_friction([lg], RIG, Coulomb(), differentiator=DIFF).per_log[0]
        for lg in (log, mirrored)
    )
    assert b.direction == 1
    assert b.params["Fc"] == pytest.approx(a.params["Fc"], abs=1e-9)
    assert b.load_cell.params["Fc"] == pytest.approx(a.load_cell.params["Fc"], abs=1e-9)


def test_fall_into_the_end_stop_is_cut_before_the_impact():
    sim = _free_fall(1, duration=0.3, x0=0.08)  # reaches x = 0 at t = 0.262 s
    impact = sim.trajectory.t[np.argmax(sim.trajectory.contact)]
    r = identify_friction([sim.log], RIG, Coulomb(), differentiator=DIFF).per_log[0]
    assert 0.1 <= r.t_start and r.t_end < impact
    assert _inside(r.ci["Fc"], FC_TRUE) and _inside(r.load_cell.ci["Fc"], FC_TRUE)


def test_other_differentiator_reach_and_segment():
    t = np.arange(300) * 1e-3
    assert derivative_reach(t, DIFF) == 25
    assert derivative_reach(t, SmoothedFiniteDifference(MovingAverage(11))) == 6
    v = np.r_[np.zeros(50), np.full(100, 0.5), np.zeros(10), np.full(140, 0.5)]
    assert sliding_segment(v, 0.02, 5) == (165, 300)  # longest run; the log's end is kept


# -- Coulomb + viscous ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def viscous_falls():
    """b = 5 N s/m: time constant (M + m1)/b = 0.15 s against 0.3 s of sliding from x0 = 0.19 m."""
    effects = ({"kind": "viscous", "b": 5.0},)
    return [_free_fall(s, duration=0.4, x0=0.19, effects=effects) for s in (1, 2, 3)]


def test_coulomb_viscous_recovers_fc_and_b(viscous_falls):
    est = identify_friction(
        [s.log for s in viscous_falls], RIG, CoulombViscous(), differentiator=DIFF
    )
    for r in est.per_log:  # measured half-widths ~0.044 N and ~0.074 N s/m
        assert _inside(r.ci["Fc"], FC_TRUE) and _inside(r.ci["b"], 5.0), r
        assert _inside(r.load_cell.ci["b"], 5.0) and 1.4 < r.durbin_watson < 2.6
    assert _inside(est.ci["Fc"], FC_TRUE) and _inside(est.ci["b"], 5.0)
    assert np.diff(est.ci["Fc"])[0] < 0.06 and np.diff(est.ci["b"])[0] < 0.12
    np.testing.assert_allclose(est.friction([-0.4, 0.4]), [-0.35 - 2.0, 0.35 + 2.0], atol=0.05)


def test_coulomb_fit_to_viscous_data_shows_in_the_residuals(viscous_falls):
    est = identify_friction([viscous_falls[0].log], RIG, Coulomb(), differentiator=DIFF)
    assert est.per_log[0].durbin_watson < 0.5  # structured residuals: the model is missing a term


def test_the_law_check_rejects_coulomb_on_viscous_falls_and_names_the_fix(viscous_falls):
    est = identify_friction([s.log for s in viscous_falls], RIG, Coulomb(), differentiator=DIFF)
    law = est.law
    assert law.rejected and law.viscous and law.f_p < 1e-6 and law.runs_p < 0.01
    assert law.b_ci[0] < 5.0 < law.b_ci[1]  # the viscous coefficient the level absorbed
    assert "friction.model: coulomb_viscous" in law.message()
    assert est.to_dict()["law_check"]["rejected"] is True
    right = identify_friction(
        [s.log for s in viscous_falls], RIG, CoulombViscous(), differentiator=DIFF
    )
    assert not right.law.rejected  # the right law leaves runs of chance length


def test_the_law_check_accepts_coulomb_falls(demo_falls):
    est = identify_friction([s.log for s in demo_falls], RIG, Coulomb(), differentiator=DIFF)
    assert not est.law.rejected and est.law.message() == ""
    assert est.law.f_p > 0.01 and est.law.runs_p > 0.01


def test_coulomb_viscous_on_coulomb_data_has_b_interval_around_zero():
    """Regression: finite-difference Jacobians made the b interval ~4x too narrow near b = 0."""
    logs = [_free_fall(s, duration=0.4, x0=0.19).log for s in range(200, 210)]
    est = identify_friction(logs, RIG, CoulombViscous(), differentiator=DIFF)
    assert np.mean([_inside(r.ci["b"], 0.0) for r in est.per_log]) >= 0.8
    assert _inside(est.ci["b"], 0.0) and _inside(est.ci["Fc"], FC_TRUE)


# -- outputs ------------------------------------------------------------------------------------
def test_estimate_serialises_tabulates_and_plots(demo_falls, tmp_path):
    logs = [s.log for s in demo_falls]
    est = identify_friction(logs, RIG, Coulomb(), differentiator=DIFF)
    record = json.loads(json.dumps(est.to_dict()))
    assert record["model"] == "coulomb" and len(record["logs"]) == 3
    assert record["ci"]["Fc"] == list(est.ci["Fc"]) and record["heterogeneity"]["dof"] == 2
    table = est.table()
    assert list(table["log"]) == [*(lg.source for lg in logs), "pooled"]
    assert {"Fc [N]", "Fc lo [N]", "Fc hi [N]", "Fc (load cell) [N]", "R2"} <= set(table.columns)
    path = plot_free_fall(logs, est, tmp_path / "free_fall.png")
    assert path.stat().st_size > 10_000


def test_a_cached_estimate_plots_logs_read_from_another_working_folder(demo_falls, tmp_path):
    # issue 31: a run from another folder reads the same files by another relative path
    logs = [s.log for s in demo_falls]
    est = identify_friction(logs, RIG, Coulomb(), differentiator=DIFF)
    moved = [replace(log, source=f"../elsewhere/{log.source}") for log in logs]
    assert plot_free_fall(moved, est, tmp_path / "free_fall.png").stat().st_size > 10_000


def test_each_row_says_what_its_intervals_are_and_whether_they_are_calibrated(demo_falls):
    """White x noise: calibrated. x noise correlated over ~66 samples (AR(1) phi 0.97, sd 1 mm,
    added to the logged position) lies beyond what the benchmark calibrated (its phi 0.97 case
    misses the band), and the table says so."""
    logs = [s.log for s in demo_falls]
    table = identify_friction(logs, RIG, Coulomb(), differentiator=DIFF).table()
    assert table["interval"].str.startswith("95 % Student t").all()
    assert table["calibration"].str.startswith("calibrated").all(), table["calibration"]
    assert (table["τ_int [samples]"].iloc[:-1] < 3).all()
    rng = np.random.default_rng(5)
    correlated = []
    for log in logs:
        e = np.zeros(len(log))
        e[0] = rng.normal(0.0, 1e-3)
        for k in range(1, len(e)):
            e[k] = 0.97 * e[k - 1] + rng.normal(0.0, 1e-3 * np.sqrt(1 - 0.97**2))
        correlated.append(log.with_channels(x=log["x"] + e))
    table = identify_friction(correlated, RIG, Coulomb(), differentiator=DIFF).table()
    assert table["calibration"].str.startswith("BEYOND calibration").all(), table
    assert (table["τ_int [samples]"].iloc[:-1] > 16).all()
    record = identify_friction(correlated, RIG, Coulomb(), differentiator=DIFF).to_dict()
    assert record["intervals"]["status"].startswith("BEYOND calibration")
    assert record["logs"][0]["tau_int"] > 16


def test_single_log_has_no_heterogeneity_test(demo_falls):
    est = identify_friction([demo_falls[0].log], RIG, Coulomb(), differentiator=DIFF)
    assert est.q_dof == 0 and np.isnan(est.q_p)
    assert json.loads(json.dumps(est.to_dict()))["heterogeneity"]["p"] is None


# -- errors -------------------------------------------------------------------------------------
def test_too_short_a_fall_names_the_log():
    log = _free_fall(1, duration=0.15).log  # 50 samples slide, 25 trimmed after the release
    pattern = r"^simulated:ff-1: the free-fall sliding segment has \d+ samples"
    with pytest.raises(LogError, match=pattern) as err:
        identify_friction([log], RIG, Coulomb(), differentiator=DIFF)
    assert "\n" not in str(err.value) and "longer fall" in str(err.value)


def test_missing_or_bad_inputs_are_one_line_errors(demo_falls):
    no_x = Log(pd.DataFrame({"t": np.arange(100) * 1e-3, "F": np.zeros(100)}), "rig/ff.csv")
    checks = [
        (lambda: identify_friction([no_x], RIG, Coulomb(), differentiator=DIFF), LogError,
         r"^rig/ff\.csv: a free-fall log needs the position channel 'x'$"),
        (lambda: identify_friction([], RIG, Coulomb(), differentiator=DIFF), LogError, "no free"),
        (lambda: identify_friction([demo_falls[0].log], None, Coulomb(), differentiator=DIFF),
         ConfigError, r"^friction needs the free fall's mass and drive"),
        (lambda: FallRig(0.0, 4.9), ValueError, r"free-fall mass=0.0 must be a positive"),
    ]  # fmt: skip
    for call, kind, pattern in checks:
        with pytest.raises(kind, match=pattern) as err:
            call()
        assert "\n" not in str(err.value)
    bad = demo_falls[0].log.data.copy()
    bad.loc[7, "x"] = np.nan
    with pytest.raises(LogError, match=r"^bad\.csv: friction: column 'x' row 7 is not finite"):
        identify_friction([Log(bad, "bad.csv")], RIG, Coulomb(), differentiator=DIFF)


def test_logs_that_scatter_beyond_their_intervals_widen_the_pooled_one():
    """The Birge ratio: three estimates 10 standard errors apart widen the pooled covariance by
    Q / dof; estimates that agree leave it the inverse-variance one (never narrower)."""
    from hmid.friction._identify import _pool

    covs = [np.array([[0.01]])] * 3
    _, cov, q, dof = _pool([np.array([v]) for v in (0.0, 1.0, 2.0)], covs)
    assert (q, dof) == (pytest.approx(200.0), 2)
    assert cov[0, 0] == pytest.approx(0.01 / 3 * 100.0)
    _, cov, q, _ = _pool([np.array([v]) for v in (0.0, 0.05, 0.1)], covs)
    assert q < 2 and cov[0, 0] == pytest.approx(0.01 / 3)
