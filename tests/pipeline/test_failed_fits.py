"""One family's failure is not the run's failure: a start that does not converge, or a fit that
diverges, is left out with its reason; the comparison and the loop go on with the others."""

import json

import numpy as np
import pytest
import yaml
from test_identify import DATASET, EXPERIMENT

from hmid.config import load_yaml_model
from hmid.families import FitContext, FitData
from hmid.families.polynomial import PolynomialSpec
from hmid.pipeline.fits import Fits, diverged, fit_or_fail
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.write import write_dataset
from pipelines.identify import run


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    root = tmp_path_factory.mktemp("failures")
    (root / "set.yaml").write_text(DATASET)
    write_dataset(load_yaml_model(root / "set.yaml", HydroMuscleDataset), root / "data")
    return root


def test_a_start_that_does_not_converge_fails_its_family_alone(workspace):
    config = json.loads(json.dumps(EXPERIMENT)) | {
        "models": [
            {"family": "sls", "start_max_steps": 1, "stride": 8, "draws": 200},
            {"family": "polynomial", "variants": ["cubic_xvP"]},
        ],
        "loop": {"base": "sls", "candidates": ["viscous", "coulomb.x"], "draws": 100},
    }
    path = workspace / "exp.yaml"
    path.write_text(yaml.safe_dump(config))
    with pytest.warns(Warning) as caught:
        run_dir, metrics = run(path, results=workspace / "results")
    said = [str(w.message) for w in caught]
    assert (run_dir / "report.md").is_file()
    report = (run_dir / "report.md").read_text()
    assert [f["name"] for f in metrics["failed"]] == ["sls"]
    reason = metrics["failed"][0]["reason"]
    assert "did not converge after 1 steps" in reason and "start_max_steps (now 1)" in reason
    assert [m["model"] for m in metrics["held_out"]] == ["poly:cubic_xvP"]
    # the loop starts from the converged model, and says so in one line, console and report
    assert metrics["loop"]["base"] == "poly:cubic_xvP"
    note = metrics["loop"]["notes"][0]  # first: before any finding of the loop itself
    assert note.startswith("loop.base sls failed") and note in said and note in report
    assert any(s.startswith("sls (sls) failed and is left out") for s in said)
    assert "failed fits" in report


def test_a_prediction_orders_above_the_force_is_a_divergence(workspace, ch4_rig):
    from hmid.experiment import load_experiment
    from pipelines.identify import analyse

    path = workspace / "exp-poly.yaml"
    path.write_text(yaml.safe_dump(EXPERIMENT))
    artifacts = analyse(load_experiment(path), ("split",), workspace / "cache")
    signals = artifacts["split"].signals
    hidden = signals.with_columns(target=np.where(signals.train, signals.target, np.nan))
    data = FitData(hidden, ch4_rig)
    spec = PolynomialSpec(variants=["cubic_xvP"])
    good, failed = fit_or_fail(spec, data, FitContext(0, workspace))
    assert len(good) == 1 and not failed and diverged(good[0], data) is None

    class Runaway:  # a model whose held-out prediction ran off, as an SLS with tau = 1e198 s
        def __init__(self, model):
            self.model = model

        def predict(self, part):
            y = self.model.predict(part)
            return y * 1e5 if part.role == "validation" else y

        def __getattr__(self, name):
            return getattr(self.model, name)

    reason = diverged(Runaway(good[0]), data)
    assert reason.startswith("it diverged: its prediction on the held-out rows")
    fits = Fits(tuple(good))
    assert list(fits) == good and fits[0] is good[0] and len(fits) == 1 and not fits.failed


def test_a_free_run_that_raises_is_the_models_line_not_the_runs_end(monkeypatch):
    """One model's free run failing on its numbers (here a band that overflows) leaves a run
    without blocks that says why; a programming error (a wrong call, numpy's shape mismatch)
    still raises."""
    from types import SimpleNamespace

    import hmid.portable.freerun as freerun
    from hmid.pipeline.stages import free_run_or_why

    def overflowing(model, signals, spans, **options):
        raise FloatingPointError("overflow encountered in the band's draws")

    monkeypatch.setattr(freerun, "simulate_signals", overflowing)
    run = free_run_or_why(SimpleNamespace(name="sls"), None, [], draws=20)
    assert run.model == "sls" and run.runs == ()
    assert run.skipped == (
        "free run failed (FloatingPointError: overflow encountered in the band's draws)"
    )

    for mistake in (TypeError("an unexpected keyword argument"), ValueError("shapes (3,) (4,)")):

        def mistaken(model, signals, spans, mistake=mistake, **options):
            raise mistake

        monkeypatch.setattr(freerun, "simulate_signals", mistaken)
        with pytest.raises(type(mistake)):
            free_run_or_why(SimpleNamespace(name="sls"), None, [])
