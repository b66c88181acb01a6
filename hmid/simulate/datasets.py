"""One entry point for every simulated rig: read a data-set config, write its data set.

A config's top-level ``kind`` names the rig: ``linear_motor`` is the positioning stage
(:class:`~hmid.simulate.stage_dataset.StageDatasetConfig`); without ``kind`` it is the Hydro
Muscle rig (:class:`~hmid.simulate.dataset.DatasetConfig`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, ValidationError

from hmid._messages import format_validation_error
from hmid.config import read_yaml
from hmid.errors import ConfigError
from hmid.simulate.dataset import DatasetConfig
from hmid.simulate.stage_dataset import StageDatasetConfig
from hmid.simulate.stage_write import write_stage_dataset
from hmid.simulate.write import write_dataset

#: Rig kinds selected by a config's top-level ``kind`` (absent: the Hydro Muscle rig).
KINDS: dict[str, type[BaseModel]] = {"linear_motor": StageDatasetConfig}

AnyDatasetConfig = DatasetConfig | StageDatasetConfig


def load_dataset_config(path: str | Path) -> AnyDatasetConfig:
    """Read a simulation config of any rig; every problem is a one-line :class:`ConfigError`."""
    data = read_yaml(path, "simulation config", " with 'seed' and 'logs' keys")
    kind = data.get("kind")
    if kind is None:
        model: type[BaseModel] = DatasetConfig
    elif isinstance(kind, str) and kind in KINDS:
        model = KINDS[kind]
    else:
        raise ConfigError(
            f"{path}: key 'kind': unknown rig {kind!r}; use one of {', '.join(KINDS)} "
            "(or leave it out for the Hydro Muscle rig)"
        )
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, str(path), model)) from None


def write_any(
    config: AnyDatasetConfig,
    folder: str | Path,
    *,
    replace: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Simulate every log of ``config``, whatever its rig, into ``folder``."""
    if isinstance(config, StageDatasetConfig):
        return write_stage_dataset(config, folder, replace=replace, progress=progress)
    if isinstance(config, DatasetConfig):
        return write_dataset(config, folder, replace=replace, progress=progress)
    raise TypeError(f"not a data-set config: {type(config).__name__}")
