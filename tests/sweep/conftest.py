"""A tiny simulated data set and a base experiment (polynomial family only) for sweep tests."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.write import write_dataset

DATASET = {
    "seed": 11,
    "logs": [
        {"name": "sine", "kind": "dynamic", "duration": 3, "profile": {"kind": "sine"}},
        {"name": "chirp", "kind": "dynamic", "duration": 3,
         "profile": {"kind": "chirp", "f0": 0.2, "f1": 1.5}},
        {"name": "ff1", "kind": "free_fall", "duration": 0.3, "x0": 0.15},
        {"name": "ff2", "kind": "free_fall", "duration": 0.3, "x0": 0.17},
    ],
}  # fmt: skip

BASE = {
    "name": "tiny",
    "seed": 3,
    "rig": yaml.safe_load((Path(__file__).resolve().parents[2] / "configs/demo.yaml").read_text())[
        "rig"
    ],
    "logs": [
        {"path": "../data/sine.csv", "columns": "../data/columns-dynamic.yaml", "role": "dynamic"},
        {"path": "../data/chirp.csv", "columns": "../data/columns-dynamic.yaml", "role": "dynamic"},
        {"path": "../data/ff1.csv", "columns": "../data/columns-free_fall.yaml",
         "role": "free_fall"},
        {"path": "../data/ff2.csv", "columns": "../data/columns-free_fall.yaml",
         "role": "free_fall"},
    ],
    "friction": {"model": "coulomb", "v_min": 0.05},
    "split": {"kind": "time_block", "validation_fraction": 0.25},
    "models": [{"family": "polynomial", "variants": ["quadratic_xv"]}],
}  # fmt: skip


@pytest.fixture(scope="session")
def workspace(tmp_path_factory) -> Path:
    """``data/`` (simulated logs), ``experiments/base.yaml`` (paths relative to its folder),
    ``garbage.csv`` (not a log) and ``sweeps/`` for sweep configs."""
    root = tmp_path_factory.mktemp("sweep")
    write_dataset(HydroMuscleDataset.model_validate(DATASET), root / "data")
    (root / "experiments").mkdir()
    (root / "experiments/base.yaml").write_text(yaml.safe_dump(BASE, sort_keys=False))
    (root / "garbage.csv").write_text("this is,not a log\n1,2\n")
    (root / "sweeps").mkdir()
    return root


@pytest.fixture(scope="session")
def sweep_file(workspace):
    """``sweep_file(name, **fields)``: a sweep config in ``sweeps/`` on the base experiment."""

    def write(name: str, **fields) -> Path:
        path = workspace / "sweeps" / f"{name}.yaml"
        data = {"name": name, "base": "../experiments/base.yaml", **fields}
        path.write_text(yaml.safe_dump(data, sort_keys=False))
        return path

    return write
