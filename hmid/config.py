"""Typed, immutable configs read from YAML: every problem is a one-line :class:`ConfigError`."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from hmid.errors import ConfigError
from hmid.io._config_errors import format_validation_error

M = TypeVar("M", bound=BaseModel)


def read_yaml(path: str | Path) -> dict:
    """The mapping at the top of a YAML file; unreadable files and bad syntax are ConfigErrors."""
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{source}: cannot read config: {err.__class__.__name__}: {err}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{source}: not valid YAML{line}: {getattr(err, 'problem', err)}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: a config must be a YAML mapping, got {type(data).__name__}")
    return data


def load_yaml_model(path: str | Path, model: type[M]) -> M:
    """Read ``path`` and validate it as ``model``; unknown keys and bad values name the key."""
    data = read_yaml(path)
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, str(path), model)) from None
