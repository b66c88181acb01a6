"""The SINDy family as the pipeline calls it: config, fit on FitData, one-step predictions,
free run on held-out blocks, report extras, pickling; config errors named."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
import yaml
from _sindy_truth import TRUE, sequences
from pydantic import ValidationError

import hmid.families.sindy  # noqa: F401  (registers the family)
from hmid.balance import Signals
from hmid.errors import ConfigError
from hmid.experiment import ExperimentConfig
from hmid.families import FitContext, FitData, make_family
from hmid.families.sindy import SINDySpec

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
    assert extras.free_run.diverged == 0
    assert extras.free_run.rmse_x_m < 5e-5
    assert any("Conditional on the selected support" in note for note in fitted.notes)
    assert extras.intervals == "autocov"
    on = table["selected"]
    assert (
        table.loc[on, "interval"].str.endswith("autocovariance sandwich, given the support").all()
    )


def test_report_extras_give_equation_threshold_and_free_run_figure(fitted, tmp_path):
    extras = fitted.model.report_extras()
    assert "Equation of motion" in extras.text and "kg" in extras.text
    assert "one-standard-error rule" in extras.text and "Free run" in extras.text
    (figure,) = extras.figures
    path = figure.draw(*figure.args, tmp_path / figure.file)
    assert path.is_file() and path.stat().st_size > 10_000 and "free run" in figure.caption.lower()
    captions = [c for _, c in extras.tables]
    assert any("Threshold path" in c for c in captions)
    assert any("Free run" in c for c in captions)
    (supports,) = [t for t, c in extras.tables if c.startswith("Candidate supports")]
    assert supports["chosen"].sum() == 1 and "supports that the threshold path" in extras.text
    chosen = supports.loc[supports["chosen"], "terms"].item().split(", ")
    force = fitted.model.force
    assert chosen == [f.pretty for f, c in zip(force.features_, force.coef_, strict=True) if c]


def test_fitted_model_survives_the_stage_cache(fitted, data):
    clone = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(clone.predict(data[1]), fitted.predict(data[1]))


def test_diverging_free_run_is_a_note_not_a_crash(data, true_friction, tmp_path):
    """A threshold that removes every term leaves F_m = 0: the block falls toward -x until the
    free run leaves the box around the log's motion; the fit still returns, with the time."""
    spec = SINDySpec(threshold=1e9, keep=(), ensemble={"models": 10})
    context = FitContext(3, tmp_path, true_friction)
    (model,) = spec.fit(data[0], context)
    assert model.fit_summary.extras.free_run.diverged == 1
    assert any(n.startswith("free run diverged at t = ") for n in model.notes)
    assert model.equation == "F_m = 0"


def test_free_run_is_skipped_without_friction(data, tmp_path):
    spec = SINDySpec(ensemble={"models": 10})
    (model,) = spec.fit(data[0], FitContext(3, tmp_path, None))
    assert model.model.free_run is None
    assert any("free run skipped" in note for note in model.notes)


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
