"""Building a typed config from a registry of plug-ins (term kinds, model families) by its tag."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from hmid._messages import format_validation_error
from hmid.errors import ConfigError

_M = TypeVar("_M", bound=BaseModel)


def from_registry(
    spec: Mapping[str, Any] | _M,
    base: type[_M],
    registry: Mapping[str, type[_M]],
    *,
    tag: str,
    what: str,
    source: str,
) -> _M:
    """``registry[spec[tag]]`` validated from ``spec`` (an instance of ``base`` passes through);
    an absent or unknown tag, or a bad key, is a one-line ConfigError naming ``source``."""
    if isinstance(spec, base):
        return spec
    if not isinstance(spec, Mapping) or tag not in spec:
        raise ConfigError(f"{source}: each entry needs a {tag!r}, one of {sorted(registry)}")
    name = spec[tag]
    if name not in registry:
        raise ConfigError(f"{source}: {what} {name!r} is unknown; known: {sorted(registry)}")
    cls = registry[name]
    try:
        return cls.model_validate(dict(spec))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, cls)) from None
