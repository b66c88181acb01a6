"""Every shipped rig (an experiment config under configs/) loads and runs through every stage,
its families at their example budgets; the measured one skips where the shared data are absent."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from hmid.errors import ConfigError
from hmid.experiment import load_experiment

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted(
    path
    for path in (ROOT / "configs").rglob("*.yaml")
    if "simulate" not in path.relative_to(ROOT / "configs").parts  # data-set configs
    and isinstance(data := yaml.safe_load(path.read_text()), dict) and data.get("rig")
    and data.get("logs")
)  # fmt: skip
#: Experiment configs whose data a make target generates rather than the repository ships
GENERATED = {
    "fibre-gastrocnemius.yaml": "make fibre-models",
    "fibre-soleus.yaml": "make fibre-models",
}


def test_the_shipped_rigs_are_the_documented_four():
    names = {p.relative_to(ROOT / "configs").as_posix() for p in SHIPPED}
    assert {"demo.yaml", "knee.yaml", "linear-motor.yaml", "pneumatic/o-ring.yaml"} <= names


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.relative_to(ROOT / "configs").as_posix())
def test_every_shipped_rig_runs_through_every_stage(path, tmp_path):
    from pipelines.identify import analyse

    try:
        config = load_experiment(path)
    except ConfigError as err:
        if "shared" in str(err):
            pytest.skip(f"measured data absent: {err}")
        if path.name in GENERATED and "does not exist" in str(err):
            pytest.skip(f"its data come from `{GENERATED[path.name]}` (tests/control makes them)")
        raise
    cheap = tuple(type(m).example(config.rig) if m.family == "sls" else m for m in config.models)
    config = config.model_copy(update={"models": cheap})
    artifacts = analyse(config, ("compare", "loop"), tmp_path)
    scores = artifacts["compare"].scores
    assert np.isfinite(scores["rmse (held-out)"]).all() and len(scores) == len(config.model_names())
    assert not [f.message() for m in artifacts["fit"] for f in m.findings]  # no sign finding
    if config.loop is not None:
        assert artifacts["loop"].base_name == config.loop.base
