"""The population study end to end: three shipped muscles, identified, pooled, left out."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

CONFIG = Path(__file__).parents[2] / "configs" / "population" / "muscles.yaml"


def _small_config(tmp_path: Path, muscles: int = 3) -> Path:
    data = yaml.safe_load(CONFIG.read_text(encoding="utf-8"))
    data["muscles"] = data["muscles"][:muscles]
    data["experiment"] = str(CONFIG.parent / data["experiment"])
    data["data"] = str((CONFIG.parent / data["data"]).resolve())
    data["sampler"] = {"chains": 1, "warmup": 150, "draws": 150}
    data["executor"] = {"kind": "process", "workers": 1}
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


@pytest.mark.slow
def test_the_shipped_population_runs_end_to_end(tmp_path):
    import hmid
    from hmid.population import predict_muscle
    from pipelines.population import run

    folder, metrics = run(_small_config(tmp_path), results=tmp_path / "results")
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    for name in ("report.md", "report.html", "metrics.json", "tables/exponents.csv",
                 "tables/leave_one_out.csv", "figures/law.png"):  # fmt: skip
        assert (folder / name).exists(), name
    assert metrics["exponents"] == 18
    assert "loo_median_specs_over_own" in metrics
    model = hmid.load_model(folder / "models" / "ch4.predicted.json")
    assert model.covariance is not None
    again = predict_muscle(
        folder, {"length": 0.05, "inner_diameter": 0.015, "outer_diameter": 0.02}
    )
    assert again.parameters["median"].gt(0).all()


def test_a_missing_experiment_is_named(tmp_path):
    from hmid.errors import HmidError
    from pipelines.population import run

    path = _small_config(tmp_path)
    data = yaml.safe_load(path.read_text())
    data["experiment"] = str(tmp_path / "nope.yaml")
    path.write_text(yaml.safe_dump(data))
    with pytest.raises((HmidError, OSError), match=r"nope\.yaml"):
        run(path, results=tmp_path / "results")
