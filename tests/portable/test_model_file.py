"""Model files: every family exported, read back by hmid.load_model and by a numpy-only
reference (no hmid) to the same predictions; the posterior as ArviZ netCDF; hmid.load_run."""

import json
from pathlib import Path

import numpy as np
import pytest
from _model_reference import predict as reference_predict
from _small_run import small_run

import hmid
from hmid.io import load_column_map, read_log

DATASET = """
seed: 78
logs:
  - {name: sine, kind: dynamic, duration: 8, profile: {kind: sine, frequency: 0.5}}
  - {name: chirp, kind: dynamic, duration: 8, profile: {kind: chirp, f0: 0.2, f1: 1.5}}
  - {name: ff1, kind: free_fall, duration: 0.3, x0: 0.15}
  - {name: ff2, kind: free_fall, duration: 0.3, x0: 0.17}
"""
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    root = tmp_path_factory.mktemp("portable")
    models = [{"family": "polynomial", "variants": ["cubic_xvP"]}, {"family": "sls", "stride": 4}]
    folder = small_run(root, DATASET, "portable", models)
    log = read_log(root / "data/chirp.csv", load_column_map(root / "data/columns-dynamic.yaml"))
    return hmid.load_run(folder), log


def test_every_model_has_a_file_and_the_sls_its_posterior(finished):
    result, _ = finished
    assert set(result.models) == {"poly:cubic_xvP", "sls"}
    posterior = result.models["sls"].posterior
    assert posterior.posterior["A_eff"].shape[1] == 4000
    assert abs(float(posterior.posterior["k1"].median()) / 3000 - 1) < 0.12
    for model in result.models.values():
        document = model.document
        assert document["agreement"]["relative_rms"] < 1e-9  # the file is the fitted model
        assert len(document["parameters"]) and document["units"]["target"] == "N"


@pytest.mark.parametrize("name", ["poly:cubic_xvP", "sls"])
def test_a_numpy_only_reference_gives_the_same_predictions(finished, name):
    result, log = finished
    model = result.models[name]
    signals = model.signals(log)
    frame = {c: signals[c] for c in signals.frame.columns if c not in ("log",)}
    document = json.loads(model.path.read_text())  # what another program reads
    target, explained = reference_predict(document, frame)
    ours = model.predict(log)
    assert np.allclose(
        target, model.predict_signals(signals), rtol=1e-9, atol=1e-9 * np.ptp(target)
    )
    assert np.allclose(explained, ours["predicted"], rtol=1e-9, atol=1e-9 * np.ptp(explained))


def test_loaded_models_predict_what_the_run_scored(finished):
    result, log = finished
    frame = result.models["sls"].predict(log)
    used = frame["usable"].to_numpy()
    rmse = np.sqrt(np.mean((frame["predicted"] - frame["measured"])[used] ** 2))
    held = result.scores.set_index("model").loc["sls", "rmse (held-out)"]
    assert rmse < 2 * held  # the whole log, training rows included, as well as the held-out


def test_free_run_scores_are_reported_and_the_sls_tracks_the_position(finished):
    result, log = finished
    scores = result.scores.set_index("model")
    assert scores.loc["sls", "fit % (x)"] > 90
    run = result.models["sls"].free_run(log)
    assert run.scores()["fit % (x)"] > 90 and run.scores()["diverged"] == 0


def test_a_folder_that_is_not_a_run_is_one_line(tmp_path):
    with pytest.raises(hmid.ConfigError, match=r"no metrics\.json"):
        hmid.load_run(tmp_path)
