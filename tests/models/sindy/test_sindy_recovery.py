"""Term recovery, inclusion probabilities and interval coverage against simulator truth.

Measured (``benchmarks/bench_sindy.py --study 8``, default settings but keep=(), so nothing is
spared the threshold):

* truth + white noise 0.01 N on F_m: the support {x, P, x³} in 8/8 seeds, spurious inclusion
  0.00, coefficients within 0.1 %. The old 95 % bootstrap percentile intervals covered the truth
  64/72 (89 %) over 24 seeds; the default post-selection intervals are calibrated separately
  (test_sindy_intervals.py, benchmarks/bench_calibration_sindy.py).
* thesis-level sensor chain (10-bit ADC + noise), denoised 10 ms / derivative 50 ms, F_m from
  the load cell and the true friction: support right 8/8, k3 within 0.2 % (median), but the
  alternative {x², x·P, x²·P} stays in ~30 % of the fits (median largest spurious inclusion
  0.30); coverage 24/24, bought with that selection spread. Shorter windows (5 ms / 30 ms) break
  recovery (1/8, k3 off by ~200 %); longer ones (20 ms / 100 ms) hold it in 6/8. With the
  pipeline's 2 mm/s dead band as stick_speed instead of 10 mm/s it was 6/8 (7/8 at 5 mm/s).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from _sindy_truth import COLUMNS, RIG, SPLIT_T, TRUE
from _sindy_truth import training_rows as _train
from pydantic import ValidationError

from hmid.errors import SignalError
from hmid.models import NotFittedError
from hmid.models.sindy import SINDyForceModel, SINDySettings


def _by_name(model: SINDyForceModel) -> pd.DataFrame:
    table = model.coefficient_table()
    table.index = [f.name for f in model.features_]
    return table


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_true_terms_are_selected_on_simulator_truth(truth_fits, seed):
    """keep=(): nothing is spared the threshold; CV must find {x, P, x³} on its own.
    Tolerance: every coefficient within 0.5 % of the truth; spurious inclusion < 0.2."""
    model = truth_fits[seed]
    assert set(model.selected) == set(TRUE)
    table = _by_name(model)
    for term, value in TRUE.items():
        assert table.loc[term, "value"] == pytest.approx(value, rel=5e-3)
        assert table.loc[term, "inclusion"] >= 0.95
    spurious = table.drop(index=list(TRUE))
    assert spurious["inclusion"].max() < 0.2
    assert (spurious["value"] == 0).all()


def test_default_intervals_cover_the_truth_mostly(truth_fits):
    """Coverage of the true coefficients by the 95 % intervals over 3 seeds x 3 terms (the three
    estimates are strongly correlated, so misses come in threes). Measured here 9/9, so a seed
    that misses is allowed."""
    covered = []
    for model in truth_fits.values():
        table = _by_name(model)
        low, high = table.columns[4], table.columns[5]
        covered += [table.loc[k, low] <= v <= table.loc[k, high] for k, v in TRUE.items()]
    assert sum(covered) >= 6, f"coverage {sum(covered)}/9"


def test_units_and_equation_are_physical(truth_fits):
    model = truth_fits[0]
    table = _by_name(model)
    assert table.loc["x", "unit"] == "N/m" and table.loc["x^3", "unit"] == "N/m³"
    assert table.loc["tanh(v/v0)", "unit"] == "N"
    assert [c.term for c in model.coefficients_] == list(model.selected)  # the shared contract
    assert len(model.coefficients_) == model.summary_.n_params
    equation = model.equation()
    assert equation.startswith("F_m = ") and "[N/m]·x" in equation and "[N/m³]·x³" in equation


def test_library_has_each_term_once(truth_fits):
    names = [f.name for f in truth_fits[0].features_]
    assert len(names) == len(set(names)) == 17  # 16 monomials (P linear, degree 3) + tanh(v/v0)


def test_stuck_rows_are_left_out_and_do_not_pull_in_terms(truth):
    """Stuck samples with a force that is no function of (x, v, P) (static friction) are given
    too; the fit leaves them out by |v| < stick_speed and still finds the true terms."""
    X, y = _train(truth, seed=3)
    rng = np.random.default_rng(3)
    stuck = truth[truth["stuck"] & (truth["t"] < SPLIT_T)]
    rows = pd.concat(
        [
            X.assign(F=y),
            stuck[COLUMNS].assign(v=0.0, F=stuck["F_true"] + rng.uniform(-0.5, 0.5, len(stuck))),
        ]
    ).sort_values("t")
    model = SINDyForceModel(SINDySettings(keep=()), seed=3).fit(rows[COLUMNS], rows["F"].to_numpy())
    assert model.n_stuck_ >= len(stuck)
    assert set(model.selected) == set(TRUE)
    assert any("left out" in w for w in model.summary_.warnings)


def test_global_numpy_rng_is_untouched_and_fits_reproduce_from_the_seed(truth):
    X, y = _train(truth, seed=4)
    X, y = X.iloc[::4], y[::4]
    before = np.random.get_state()  # noqa: NPY002
    a = SINDyForceModel(SINDySettings(keep=(), ensemble={"models": 20}), seed=11).fit(X, y)
    after = np.random.get_state()  # noqa: NPY002
    assert before[0] == after[0] and np.array_equal(before[1], after[1]) and before[2] == after[2]
    b = SINDyForceModel(SINDySettings(keep=(), ensemble={"models": 20}), seed=11).fit(X, y)
    c = SINDyForceModel(SINDySettings(keep=(), ensemble={"models": 20}), seed=12).fit(X, y)
    np.testing.assert_array_equal(a.ensemble_coef_, b.ensemble_coef_)
    assert not np.array_equal(a.ensemble_coef_, c.ensemble_coef_)


def test_keep_spares_terms_from_the_threshold(truth):
    X, y = _train(truth, seed=5)
    X, y = X.iloc[::4], y[::4]
    model = SINDyForceModel(
        SINDySettings(keep=("v", "x*P"), threshold=0.05, ensemble={"models": 10})
    ).fit(X, y)
    assert {"v", "x*P"} <= set(model.selected)
    assert model.inclusion_[[f.name in ("v", "x*P") for f in model.features_]].min() == 1.0


# -- thesis-level noise --------------------------------------------------------------------------
def _sensor_chain(seed: int, rig) -> pd.DataFrame:
    """The simulated log through the pipeline's denoising and balance (the rig's known friction
    subtracted), as the SINDy family sees it: usable rows of the first 70 %."""
    from hmid.balance.prepare import prepare
    from hmid.denoise import denoise_log
    from hmid.experiment import DenoiseSection
    from hmid.friction import Coulomb, FallRig, FrictionEstimate
    from hmid.simulate.rigs.hydro_muscle_dataset import DynamicLog, HydroMuscleDataset

    profile = {"kind": "chirp", "f0": 0.2, "f1": 3.0}
    config = HydroMuscleDataset(
        seed=seed, rig=RIG, logs=[DynamicLog(name="chirp", duration=30, profile=profile)]
    )
    log = config.simulate(config.logs[0]).log  # 10-bit ADC, thesis noise levels
    smoother, differentiator = DenoiseSection().build()
    log = denoise_log(log, smoother, differentiator, channels=("x", "P", "F"))
    fall = FallRig(RIG.M + RIG.m1, RIG.m1 * RIG.g)
    friction = FrictionEstimate.known(Coulomb(), {"Fc": RIG.friction.coulomb}, fall)
    units = {"x": "m", "P": "Pa", "F": "N", "v": "m/s", "a": "m/s^2", "target": "N"}
    signals = prepare(rig, {"chirp": [log]}, units, smoother=smoother,
                      differentiator=differentiator, free_fall_law=friction.friction)  # fmt: skip
    frame = signals.frame.assign(F_m=signals.target)
    frame = frame.iloc[50 : int(0.7 * len(frame))]
    return frame[frame["usable"]]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_recovery_on_quantised_noisy_logs_with_default_denoising(seed, ch4_rig):
    """Default denoising (three passes of an 11 ms moving average on both sides, velocity the
    derivative of the smoothed position) and the default stick_speed 0.01 m/s: right support;
    x and P within 1 %, x³ within 5 %. The weaker part: spurious terms reach inclusion ~0.3 (the
    {x², x·P, x²·P} alternative), so the bound here is 0.5, not the 0.2 of noise-free data."""
    frame = _sensor_chain(seed, ch4_rig)
    model = SINDyForceModel(SINDySettings(keep=()), seed=seed).fit(
        frame[COLUMNS], frame["F_m"].to_numpy()
    )
    assert set(model.selected) == set(TRUE)
    table = _by_name(model)
    assert table.loc["x", "value"] == pytest.approx(TRUE["x"], rel=0.01)
    assert table.loc["P", "value"] == pytest.approx(TRUE["P"], rel=0.01)
    assert table.loc["x^3", "value"] == pytest.approx(TRUE["x^3"], rel=0.05)
    assert table.drop(index=list(TRUE))["inclusion"].max() < 0.5


# -- errors --------------------------------------------------------------------------------------
def test_errors_are_named():
    with pytest.raises(ValidationError, match="keep names \\['x\\^5'\\]"):
        SINDySettings(keep=("x^5",))
    with pytest.raises(ValidationError, match="must be 'cv'"):
        SINDySettings(threshold="aic")
    with pytest.raises(NotFittedError):
        SINDyForceModel().predict(pd.DataFrame({"x": [0.0], "v": [0.0], "P": [0.0]}))
    few = pd.DataFrame({"x": [0.01] * 10, "v": [0.05] * 10, "P": [1e5] * 10})
    with pytest.raises(SignalError, match="10 rows cannot fit"):
        SINDyForceModel().fit(few, np.ones(10))
    stuck = pd.DataFrame({"x": [0.01] * 100, "v": [0.001] * 100, "P": [1e5] * 100})
    with pytest.raises(SignalError, match="only 0 rows have \\|v\\| >= stick_speed"):
        SINDyForceModel().fit(stuck, np.ones(100))
    with pytest.raises(SignalError, match="column 'P'"):
        SINDyForceModel().fit(few.drop(columns="P"), np.ones(10))
