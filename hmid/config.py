"""Typed, immutable configs read from YAML: every problem is a one-line :class:`ConfigError`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, TypeVar

import yaml
from pydantic import BaseModel, Field, ValidationError

from hmid._messages import format_validation_error
from hmid.errors import ConfigError

M = TypeVar("M", bound=BaseModel)

#: the constrained numbers of every config (SI units)
Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]


class _UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that rejects a key given twice (PyYAML keeps the last silently)."""


def _mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode) -> dict:
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"key {key!r} is given twice", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)


def read_yaml(path: str | Path, what: str = "config", hint: str = "") -> dict:
    """The mapping at the top of a YAML file; unreadable files and bad syntax are ConfigErrors.

    ``what`` names the kind of file in messages; ``hint`` says what the mapping should hold.
    """
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{source}: cannot read {what}: {err}") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # a SafeLoader subclass: safe
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or "syntax error"
        raise ConfigError(f"{source}: not valid YAML{line}: {problem}") from None
    if not isinstance(data, dict):
        raise ConfigError(
            f"{source}: a {what} must be a YAML mapping{hint}, got {type(data).__name__}"
        )
    return data


def load_yaml_model(path: str | Path, model: type[M], what: str = "config", hint: str = "") -> M:
    """Read ``path`` and validate it as ``model``; unknown keys and bad values name the key."""
    data = read_yaml(path, what, hint)
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, str(path), model)) from None
