"""A small simulated Ch. 4 data set through the pipeline's stages, up to the split."""

from pathlib import Path

import pytest
import yaml

from hmid.config import load_yaml_model
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.write import write_dataset

ROOT = Path(__file__).resolve().parents[2]
DATASET = """
seed: 41
logs:
  - {name: sine, kind: dynamic, duration: 8, profile: {kind: sine, frequency: 0.5}}
  - {name: chirp, kind: dynamic, duration: 8, profile: {kind: chirp, f0: 0.2, f1: 1.5}}
  - {name: ff1, kind: free_fall, duration: 0.3, x0: 0.15}
  - {name: ff2, kind: free_fall, duration: 0.3, x0: 0.17}
"""


@pytest.fixture(scope="session")
def ch4_split(tmp_path_factory):
    """(config, split, friction) of a two-log Ch. 4 experiment (polynomial placeholder model)."""
    from hmid.experiment import experiment_from
    from pipelines.identify import analyse

    root = tmp_path_factory.mktemp("families")
    (root / "set.yaml").write_text(DATASET)
    write_dataset(load_yaml_model(root / "set.yaml", HydroMuscleDataset), root / "data")
    rig = yaml.safe_load((ROOT / "configs/demo.yaml").read_text())["rig"]
    logs = [{"path": f"data/{n}.csv", "columns": "data/columns-dynamic.yaml", "role": "dynamic"}
            for n in ("sine", "chirp")]  # fmt: skip
    logs += [{"path": f"data/{n}.csv", "columns": "data/columns-free_fall.yaml",
              "role": "free_fall"} for n in ("ff1", "ff2")]  # fmt: skip
    data = {"name": "families", "seed": 5, "rig": rig, "logs": logs,
            "friction": {"v_min": 0.05}, "models": [{"family": "polynomial"}]}  # fmt: skip
    config = experiment_from(data, "families", root)
    artifacts = analyse(config, ("split", "friction"), root / "cache")
    return config, artifacts["split"], artifacts["friction"], root
