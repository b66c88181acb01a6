"""A small identified run for the tests that use a model file (portable, control): four short
simulated logs (two dynamic, two free falls) on the demo's rig, fitted with the given families."""

from pathlib import Path

import yaml

from hmid.config import load_yaml_model
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.write import write_dataset

ROOT = Path(__file__).resolve().parents[1]
LOGS = (("sine", "dynamic"), ("chirp", "dynamic"), ("ff1", "free_fall"), ("ff2", "free_fall"))


def small_run(root: Path, dataset: str, name: str, models: list[dict]) -> Path:
    """Simulate ``dataset`` (a data-set config naming the logs of :data:`LOGS`) into
    ``root/data`` and run the experiment ``name`` on it; the run's folder."""
    from pipelines.identify import run

    (root / "set.yaml").write_text(dataset)
    write_dataset(load_yaml_model(root / "set.yaml", HydroMuscleDataset), root / "data")
    config = {
        "name": name,
        "seed": 3,
        "rig": yaml.safe_load((ROOT / "configs/demo.yaml").read_text())["rig"],
        "logs": [
            {"path": f"data/{log}.csv", "columns": f"data/columns-{role}.yaml", "role": role}
            for log, role in LOGS
        ],
        "split": {"kind": "time_block", "validation_fraction": 0.25},
        "models": models,
    }
    (root / "exp.yaml").write_text(yaml.safe_dump(config))
    folder, _ = run(root / "exp.yaml", results=root / "results")
    return folder
