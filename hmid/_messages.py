"""One-line messages from pydantic validation errors, naming the file and the dotted key."""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

_PREFIXES = ("Value error, ", "Assertion failed, ")


def format_validation_error(
    err: ValidationError, source: str, model: type[BaseModel] | None = None
) -> str:
    """``"<source>: key 'a.b.c': <problem>"`` for the first problem in ``err``, on one line.

    ``model`` (the class that was validated) lets the message list the allowed keys after an
    unknown one and drop pydantic's union-member tags ('str', 'int') from key paths.
    """
    problems: dict[tuple[Any, ...], tuple[ErrorDetails, Any]] = {}
    # an unknown key is most often a misspelt one: report it before the "missing" it causes
    ordered = sorted(err.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
    for error in ordered:
        loc, holder = _clean_loc(model, error["loc"])
        problems.setdefault(loc, (error, holder))
    loc, (error, holder) = next(iter(problems.items()))
    if error["type"] == "extra_forbidden":
        allowed = _allowed_keys(holder)
        what = "unknown key" + (f"; allowed keys are {', '.join(allowed)}" if allowed else "")
    elif error["type"] == "missing":
        what = "required key is missing"
    else:
        msg = str(error["msg"])
        for prefix in _PREFIXES:
            msg = msg.removeprefix(prefix)
        what = f"{msg[:1].lower()}{msg[1:]}"
        if loc:  # a whole-model problem would echo the whole input
            what += f" (got {_short(error.get('input'))})"
    more = len(problems) - 1
    tail = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
    key = f"key {'.'.join(str(part) for part in loc)!r}: " if loc else ""
    return " ".join(f"{source}: {key}{what}{tail}".split())


def _short(value: object, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _members(tp: Any) -> list[Any]:
    """The non-None members of a union (``[tp]`` for anything else), ``Annotated`` stripped."""
    if typing.get_origin(tp) is typing.Annotated:
        return _members(typing.get_args(tp)[0])
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return [arg for arg in typing.get_args(tp) if arg is not type(None)]
    return [tp]


def _tag(member: Any) -> str | None:
    """The ``kind`` tag of a model in a discriminated union (pydantic puts it in error paths)."""
    if isinstance(member, type) and issubclass(member, BaseModel) and "kind" in member.model_fields:
        default = member.model_fields["kind"].default
        return default if isinstance(default, str) else None
    return None


def _step(tp: Any, part: object) -> tuple[Any, bool]:
    """(type one level down at ``part``, whether ``part`` is a real key rather than a union tag)."""
    members = _members(tp)
    if len(members) > 1:
        # pydantic appends the member type's name to the path of a failed union member
        named = {getattr(arg, "__name__", None): arg for arg in members}
        named |= {_tag(arg): arg for arg in members if _tag(arg) is not None}
        return (named[part], False) if part in named else (None, True)
    tp = members[0]
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        field = tp.model_fields.get(str(part))
        return (field.annotation if field else None), True
    if isinstance(origin, type) and issubclass(origin, Mapping):
        return typing.get_args(tp)[1], True
    if isinstance(origin, type) and issubclass(origin, Sequence):
        args = typing.get_args(tp)
        return (args[0] if args else None), True
    return None, True


def _clean_loc(model: type[BaseModel] | None, loc: tuple[Any, ...]) -> tuple[tuple[Any, ...], Any]:
    """(the key path without union tags, the type that holds the last key)."""
    if model is None:
        return tuple(loc), None
    kept, tp, holder = [], model, None
    for part in loc:
        down, real = _step(tp, part)
        if real:
            kept.append(part)
            holder = tp
        tp = down
    return tuple(kept), holder


def _allowed_keys(holder: Any) -> list[str]:
    for member in _members(holder):
        if isinstance(member, type) and issubclass(member, BaseModel):
            return list(member.model_fields)
    return []
