"""The SINDy family as the pipeline calls it: config, fit on FitData, one-step predictions,
report extras, pickling, its model run free by the integrator every family shares; config
errors named."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
import yaml
from _sindy_truth import SPLIT_T, TRUE, sequences
from pydantic import ValidationError

import hmid.families.sindy  # noqa: F401  (registers the family)
from hmid.balance import Signals
from hmid.errors import ConfigError
from hmid.experiment import ExperimentConfig
from hmid.families import FitContext, FitData, make_family
from hmid.families.sindy import SINDySpec
from hmid.portable import Model
from hmid.portable.export import model_document
from hmid.portable.freerun import blocks, simulate_signals

ROOT = Path(__file__).resolve().parents[3]
EXPERIMENT = {
    "name": "sindy",
    "seed": 3,
    "rig": yaml.safe_load((ROOT / "configs/demo.yaml").read_text())["rig"],
    "logs": [
        {"path": "a.csv", "columns": "a.yaml", "role": "dynamic"},
        {"path": "b.csv", "columns": "b.yaml", "role": "free_fall"},
    ],
}
UNITS = {"x": "m", "v": "m/s", "P": "Pa", "target": "N"}


def _data(truth, rig, noise: float = 0.01) -> tuple[FitData, FitData]:
    seq = sequences(truth)["chirp"].copy()
    seq["target"] = seq["F_m"] + noise * np.random.default_rng(5).standard_normal(len(seq))
    seq["explained"] = seq["target"]  # the free run's force score only (x is what is tested)
    signals = Signals.from_frame(seq.assign(log="chirp"), UNITS, position="x")
    return FitData(signals, rig, "train"), FitData(signals, rig, "validation")


@pytest.fixture(scope="module")
def data(truth, ch4_rig):
    return _data(truth, ch4_rig)


@pytest.fixture(scope="module")
def fitted(data, true_friction, tmp_path_factory):
    context = FitContext(3, tmp_path_factory.mktemp("work"), true_friction)
    (model,) = SINDySpec().fit(data[0], context)
    return model


def test_default_family_fit_finds_the_truth_and_scores_one_step(fitted, data):
    assert fitted.name == "sindy:stlsq" and fitted.family == "sindy" and fitted.kind == "one-step"
    extras = fitted.fit_summary.extras
    assert set(extras.selected_terms) == set(TRUE)
    table = fitted.coefficients
    assert {"term", "value", "unit", "inclusion", "kept by config"} <= set(table.columns)
    held = fitted.predict(data[1])
    assert held.shape == (int(data[1].rows.sum()),)
    assert np.sqrt(np.mean((held - data[1].y) ** 2)) < 0.02  # N; the target noise is 0.01 N
    json.dumps(fitted.fit_summary.to_dict())  # metrics.json
    assert any("Conditional on the selected support" in note for note in fitted.notes)
    assert extras.intervals == "autocov"
    on = table["selected"]
    assert (
        table.loc[on, "interval"].str.endswith("autocovariance sandwich, given the support").all()
    )


def test_report_extras_give_threshold_and_supports(fitted):
    extras = fitted.model.report_extras()
    assert "one-standard-error rule" in extras.text
    assert "Free run" not in extras.text and not extras.figures  # the pipeline's, every family's
    captions = [c for _, c in extras.tables]
    assert any("Threshold path" in c for c in captions)
    assert not any("Free run" in c for c in captions)
    (supports,) = [t for t, c in extras.tables if c.startswith("Candidate supports")]
    assert supports["chosen"].sum() == 1 and "supports that the threshold path" in extras.text
    chosen = supports.loc[supports["chosen"], "terms"].item().split(", ")
    force = fitted.model.force
    assert chosen == [f.pretty for f, c in zip(force.features_, force.coef_, strict=True) if c]


def test_fitted_model_survives_the_stage_cache(fitted, data):
    clone = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(clone.predict(data[1]), fitted.predict(data[1]))


def _free_run(model, data, friction):
    """``model`` exported and run free over the held-out blocks, as the pipeline's freerun
    stage does (:mod:`hmid.portable.freerun`, the integrator every family shares)."""
    document = model_document(model, data[0], units=UNITS | {"explained": "N"}, denoise={},
                              fit={}, friction=friction)  # fmt: skip
    signals = data[1].signals
    return simulate_signals(Model(document), signals, blocks(signals))


def test_the_exported_model_runs_free_and_tracks_the_held_out_truth(fitted, data, true_friction):
    """9 s held-out, from the measured state at its start, driven by the true P, through the
    rig's balance and motion and the free-fall friction. Tolerance: x RMSE below 0.05 mm
    (measured 0.021 mm; the rig's x spans ~10 mm, its stick band 2 Fc/k ~0.2 mm, which the
    regularised sign creeps through)."""
    run = _free_run(fitted, data, true_friction)
    assert not run.skipped and run.runs
    (block,) = run.runs
    assert block.diverged_at is None
    assert block.t[0] == pytest.approx(SPLIT_T, abs=0.05) and block.t[-1] == pytest.approx(30.0)
    assert np.ptp(block.x_measured) > 5e-3  # the block does move
    scores = run.scores()
    assert scores["diverged"] == 0 and scores["rmse x"] < 5e-5


def test_a_diverging_free_run_says_when_and_does_not_raise(data, true_friction, tmp_path):
    """A threshold that removes every term leaves F_m = 0: the block falls toward -x until the
    free run leaves the box around the log's motion; the run returns, with the time."""
    spec = SINDySpec(threshold=1e9, keep=(), ensemble={"models": 10})
    (model,) = spec.fit(data[0], FitContext(3, tmp_path, true_friction))
    assert model.equation == "F_m = 0"
    run = _free_run(model, data, true_friction)
    (block,) = run.runs
    assert block.t[0] < block.diverged_at < block.t[-1]
    assert "left the measured range" in block.reason
    assert run.scores()["diverged"] == 1


def test_pysindy_velocity_option_is_used_for_fit_and_scoring(data, true_friction, tmp_path):
    spec = SINDySpec(velocity={"kind": "smoothed_finite_difference", "window_s": 0.03},
                     ensemble={"models": 10})  # fmt: skip
    (model,) = spec.fit(data[0], FitContext(3, tmp_path, true_friction))
    held = model.predict(data[1])  # v re-estimated on the whole log
    assert np.sqrt(np.mean((held - data[1].y) ** 2)) < 0.05
    assert "SmoothedFiniteDifference" in model.model.velocity_label


@pytest.mark.parametrize(
    ("entry", "match"),
    [
        ({"family": "sindy", "degree": 7}, r"models\.0: key 'degree': input should be less"),
        ({"family": "sindy", "treshold": 0.1}, r"models\.0: key 'treshold': unknown key"),
        ({"family": "sindy", "threshold": "aic"}, r"key 'threshold': must be 'cv'"),
        ({"family": "sindy", "keep": ["x^5"]}, r"keep names \['x\^5'\]"),
        ({"family": "sindy", "velocity": {"kind": "kalman"}}, r"key 'velocity'"),
        # the free run is the pipeline's for every family (hmid.portable.freerun)
        ({"family": "sindy", "free_run": {"enabled": False}}, r"key 'free_run': unknown key"),
    ],
)
def test_config_errors_name_the_key(entry, match):
    with pytest.raises(ValidationError, match=match):
        ExperimentConfig.model_validate(EXPERIMENT | {"models": [entry]})
    with pytest.raises(ConfigError, match=match):
        make_family(entry, "models.0")


def test_config_round_trips_and_is_frozen():
    spec = make_family({"family": "sindy", "name": "quad", "degree": 2, "cv": {"folds": 4}})
    assert isinstance(spec, SINDySpec) and spec.cv.folds == 4 and spec.max_degree == {"P": 1}
    assert SINDySpec.model_validate(spec.model_dump(mode="json")) == spec
    with pytest.raises(ValidationError):
        spec.degree = 3
