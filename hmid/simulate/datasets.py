"""Which rig a data-set config is for: read it, as the rig's own config class.

A config's top-level ``kind`` names the rig: ``linear_motor`` is the positioning stage
(:class:`~hmid.simulate.rigs.linear_motor_dataset.LinearMotorDataset`); without ``kind`` it is
the Hydro Muscle rig (:class:`~hmid.simulate.rigs.hydro_muscle_dataset.HydroMuscleDataset`).
:func:`hmid.simulate.write.write_dataset` writes either.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError

from hmid._messages import format_validation_error
from hmid.config import read_yaml
from hmid.errors import ConfigError
from hmid.simulate.dataset import RigDataset
from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
from hmid.simulate.rigs.linear_motor_dataset import LinearMotorDataset

#: Rig kinds selected by a config's top-level ``kind`` (absent: the Hydro Muscle rig).
KINDS: dict[str, type[RigDataset]] = {"linear_motor": LinearMotorDataset}


def load_dataset_config(path: str | Path) -> RigDataset:
    """Read a simulation config of any rig; every problem is a one-line :class:`ConfigError`."""
    data = read_yaml(path, "simulation config", " with 'seed' and 'logs' keys")
    kind = data.get("kind")
    if kind is None:
        model: type[RigDataset] = HydroMuscleDataset
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
