"""A finished identification run whose models the control tests load: a small simulated data
set of the Ch. 4 rig (a sine, a chirp, two free falls), the SLS fitted, once per session."""

from pathlib import Path

import pytest
import yaml
from _small_run import small_run

from hmid.config import load_yaml_model
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.write import write_dataset

ROOT = Path(__file__).resolve().parents[2]
DATASET = """
seed: 33
logs:
  - {name: sine, kind: dynamic, duration: 8,
     profile: {kind: sine, offset: 140000, amplitude: 100000, frequency: 0.5}}
  - {name: chirp, kind: dynamic, duration: 8,
     profile: {kind: chirp, offset: 140000, amplitude: 80000, f0: 0.1, f1: 2.0}}
  - {name: ff1, kind: free_fall, duration: 0.3, x0: 0.15}
  - {name: ff2, kind: free_fall, duration: 0.3, x0: 0.17}
"""


@pytest.fixture(scope="session")
def identified(tmp_path_factory) -> Path:
    """The experiment folder (results/<name>) of a complete run with an SLS model file."""
    root = tmp_path_factory.mktemp("control-models")
    models = [{"family": "sls", "stride": 4}, {"family": "polynomial", "variants": ["cubic_xv"]}]
    folder = small_run(root, DATASET, "muscle", models)
    return folder.parent


FIBRE_LOGS = """
  - {name: sine, kind: dynamic, duration: 8,
     profile: {kind: sine, offset: 280000, amplitude: 240000, frequency: 0.5}}
  - {name: chirp, kind: dynamic, duration: 8,
     profile: {kind: chirp, offset: 280000, amplitude: 150000, f0: 0.1, f1: 1.0}}
  - {name: ff1, kind: free_fall, duration: 0.3, x0: 0.15}
  - {name: ff2, kind: free_fall, duration: 0.3, x0: 0.17}
"""


@pytest.fixture(scope="session")
def fibre_models(tmp_path_factory) -> dict[str, Path]:
    """Per ankle fibre type, the experiment folder of a complete run with its SLS model: the
    shipped fibre data set (configs/simulate/fibre-*.yaml) with shorter logs, identified by the
    shipped experiment config (configs/fibre-*.yaml)."""
    from pipelines.identify import run

    root = tmp_path_factory.mktemp("fibre-models")
    out = {}
    for fibre in ("gastrocnemius", "soleus"):
        dataset = yaml.safe_load((ROOT / f"configs/simulate/fibre-{fibre}.yaml").read_text())
        dataset["logs"] = yaml.safe_load(FIBRE_LOGS)
        (root / f"{fibre}.yaml").write_text(yaml.safe_dump(dataset))
        data = root / f"data-{fibre}"
        write_dataset(load_yaml_model(root / f"{fibre}.yaml", HydroMuscleDataset), data)
        config = yaml.safe_load((ROOT / f"configs/fibre-{fibre}.yaml").read_text())
        config["logs"] = [
            {"path": f"{data.name}/{name}.csv", "columns": f"{data.name}/columns-{role}.yaml",
             "role": role}
            for name, role in (("sine", "dynamic"), ("chirp", "dynamic"),
                               ("ff1", "free_fall"), ("ff2", "free_fall"))
        ]  # fmt: skip
        config["split"] = {"kind": "time_block", "validation_fraction": 0.25}
        (root / f"exp-{fibre}.yaml").write_text(yaml.safe_dump(config))
        folder, _ = run(root / f"exp-{fibre}.yaml", results=root / "results")
        out[fibre] = folder.parent
    return out
