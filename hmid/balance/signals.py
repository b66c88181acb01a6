"""The rows a force balance is fitted on: every sample of every contiguous segment, in time order.

Columns of :attr:`Signals.frame`:

* ``log`` (name), ``segment`` (integer id of a contiguous piece: a log, or a piece between logger
  pauses), ``t`` (s since the log's first sample);
* every model channel **smoothed** by the experiment's zero-phase smoother (the rig's channels,
  with their declared sign, and ``v``, ``a`` derived from the position channel), and each also
  unsmoothed as ``raw:<name>`` (``raw:v`` is the differentiator's estimate alone);
* ``explained``: the measured quantity the balance explains, smoothed by the same filter, and
  ``target``: that minus every term whose coefficient is known (the free-fall friction, a weighed
  mass); models of the remaining terms are fitted to ``target``;
* ``usable`` (direction of motion known, away from filter edges), ``train`` and ``validation``.

The same smoother acts on both sides of the balance, so identified parameters do not depend on
its window (see :meth:`Signals.smooth`). Rows outside the fitting sets still carry the signals
that memory and lag terms read, so every column is evaluated on whole segments and then masked.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, TypeVar

import numpy as np
import pandas as pd

from hmid.errors import ConfigError
from hmid.signal.blocks import local_smoother, smoothed_by_blocks, smoothed_span

if TYPE_CHECKING:
    from hmid.signal import Smoother

_T = TypeVar("_T")

REQUIRED = ("log", "segment", "t", "target", "usable", "train", "validation")

_VERSIONS = itertools.count()  # a column's version: new whenever a derived set replaces it
_READING = threading.local()  # the open recordings of what is read (see :func:`recording`)


@contextmanager
def recording() -> Iterator[set]:
    """The (column, version) pairs read from any :class:`Signals` inside the block (a missing
    column read as version None), those behind cached derived values included: what a value
    computed in the block depends on, so that it can be reused wherever they are the same."""
    stack = _READING.__dict__.setdefault("stack", [])
    found: set = set()
    stack.append(found)
    try:
        yield found
    finally:
        stack.pop()


def _noted(deps: tuple | frozenset) -> None:
    for found in getattr(_READING, "stack", ()):
        found.update(deps)


def raw(channel: str) -> str:
    """Column name of a channel before smoothing."""
    return f"raw:{channel}"


@dataclass(frozen=True)
class Signals:
    """Rows of whole segments; ``units`` maps each channel (and ``target``) to its SI unit;
    ``channels`` are the model channels (smoothed), ``position`` the one v and a come from;
    ``smoother`` the zero-phase filter applied to both sides of the balance (None: none)."""

    frame: pd.DataFrame = field(repr=False)
    units: Mapping[str, str]
    channels: tuple[str, ...]
    position: str | None = None
    smoother: Smoother | None = None
    # columns and transformed signals computed from these rows (a new set starts empty)
    cache: dict = field(default_factory=dict, compare=False, repr=False)
    # each column's version: a derived set shares the versions of the columns it keeps
    versions: Mapping[str, int] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        missing = [c for c in (*REQUIRED, *self.channels) if c not in self.frame.columns]
        if missing:
            raise ValueError(f"Signals needs columns {missing}")
        if (self.frame["train"] & self.frame["validation"]).any():
            raise ValueError("a row cannot be both training and held-out")
        object.__setattr__(self, "units", MappingProxyType(dict(self.units)))
        if self.versions is None:
            versions = {c: next(_VERSIONS) for c in self.frame.columns}
            object.__setattr__(self, "versions", MappingProxyType(versions))

    @classmethod
    def from_frame(
        cls,
        frame: pd.DataFrame,
        units: Mapping[str, str],
        *,
        position: str | None = None,
        smoother=None,
    ) -> Signals:
        """Signals from a plain table: columns ``log``, ``t`` (per log), one per channel named in
        ``units`` (which also gives ``target``'s unit) and ``target``; optional ``segment``
        (default: one per log), ``usable`` (default all), ``train`` and ``validation``
        (default none) and ``raw:<channel>`` (default: the channel itself)."""
        channels = tuple(c for c in units if c != "target")
        out = frame.reset_index(drop=True).copy()
        if "segment" not in out:
            out["segment"] = pd.factorize(out["log"])[0]
        for column, default in (("usable", True), ("train", False), ("validation", False)):
            if column not in out:
                out[column] = default
            out[column] = out[column].astype(bool)
        for channel in channels:
            if raw(channel) not in out:
                out[raw(channel)] = out[channel]
        return cls(out, units, channels, position, smoother)

    # read-only mappings do not pickle; the stage cache pickles signals. Versions are this
    # process's: a loaded set gets new ones
    def __getstate__(self) -> dict:
        return self.__dict__ | {"units": dict(self.units), "cache": {}, "versions": None}

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, MappingProxyType(value) if name == "units" else value)
        versions = {c: next(_VERSIONS) for c in self.frame.columns}
        object.__setattr__(self, "versions", MappingProxyType(versions))

    @property
    def _versions(self) -> Mapping[str, int]:
        """:attr:`versions`, which ``__post_init__`` sets where none is given."""
        assert self.versions is not None
        return self.versions

    def __len__(self) -> int:
        return len(self.frame)

    def __getitem__(self, column: str) -> np.ndarray:
        versions = self._versions
        if column in versions:
            _noted(((column, versions[column]),))
        # pandas' column lookup costs ~0.2 ms on an index of strings; profiling reads thousands
        found = self.cache.get(("array", column))
        if found is None:
            found = self.cache[("array", column)] = self.frame[column].to_numpy()
        return found

    def __contains__(self, column: str) -> bool:
        _noted(((column, self._versions.get(column)),))
        return column in self.frame.columns

    @property
    def train(self) -> np.ndarray:
        return self["train"]

    @property
    def validation(self) -> np.ndarray:
        return self["validation"]

    @property
    def usable(self) -> np.ndarray:
        return self["usable"]

    @property
    def target(self) -> np.ndarray:
        return self["target"]

    def rows(self, role: str) -> np.ndarray:
        """The mask of ``role``: ``"train"`` or ``"validation"``."""
        if role not in ("train", "validation"):
            raise ValueError(f"role must be 'train' or 'validation', got {role!r}")
        return self[role]

    def derived(self, key: object, compute: Callable[[], _T]) -> _T:
        """``compute()``, once per signals and ``key`` (kept in :attr:`cache`); what it read is
        noted again on every reuse, so a recording around the caller sees it."""
        found = self.cache.get(key)
        if found is None:
            with recording() as deps:
                value = compute()
            found = self.cache[key] = (value, frozenset(deps))
        _noted(found[1])
        return found[0]

    @contextmanager
    def scoped(self) -> Iterator[Signals]:
        """What is cached inside the block is dropped after it (entries appended to a cached
        list are cut back): a candidate's transformed signals and their columns are of no use
        to the next, and the loop would otherwise hold gigabytes of them."""
        before = {key: len(v) if isinstance(v, list) else None for key, v in self.cache.items()}
        try:
            yield self
        finally:
            for key in [key for key in self.cache if key not in before]:
                del self.cache[key]
            for key, length in before.items():
                if length is not None:
                    del self.cache[key][length:]

    def reads_same(self, deps) -> bool:
        """Whether every (column, version) of ``deps`` (from :func:`recording`) holds here."""
        return all(self._versions.get(column) == version for column, version in deps)

    def segments(self) -> Iterator[np.ndarray]:
        """Row indices of each segment, in order (made as they are read: a long log's are not
        held)."""
        return (np.arange(start, stop) for start, stop in self.bounds())

    def bounds(self) -> tuple[tuple[int, int], ...]:
        """``(start, stop)`` rows of each segment, in order (found once per signals: every
        smoothing and every memory scan walks them)."""

        def split() -> tuple[tuple[int, int], ...]:
            ids = self["segment"]
            edges = [0, *(np.flatnonzero(ids[1:] != ids[:-1]) + 1).tolist(), len(ids)]
            return tuple(itertools.pairwise(edges)) if len(ids) else ()

        return self.derived(("segments",), split)

    @property
    def dt(self) -> float:
        """Median sampling step (s) of the first segment."""
        t = self["t"][:1000]
        return float(np.median(np.diff(t))) if len(t) > 1 else 1.0

    def is_logged(self, channel: str) -> bool:
        """Whether ``channel`` has an unsmoothed log behind it (not v or a, which are
        derivatives of the smoothed position, and not t)."""
        derived = ("v", "a") if self.position is not None else ()
        return channel in self.channels and channel not in derived

    def smooth(self, values: np.ndarray) -> np.ndarray:
        """``values`` through the experiment's zero-phase smoother, segment by segment: a term
        that is not linear in the signals (sign(v), a product) is evaluated first and smoothed
        after, exactly as the measured force that contains it was."""
        smoother = self.smoother
        if smoother is None:
            return np.asarray(values, dtype=float)

        def bound() -> list:  # the smoother on each segment's time base, checked once
            t = self["t"]
            return [(slice(*b), smoother.on(t[slice(*b)])) for b in self.bounds()]

        out = np.empty(len(self))
        for rows, smooth in self.derived(("smoothers",), bound):
            out[rows] = smooth(values[rows])
        return out

    def smooth_at(self, values_of: Callable[[slice], np.ndarray], rows: np.ndarray) -> np.ndarray:
        """``smooth(values)[rows]`` (``rows`` increasing), where ``values_of(s)`` gives the
        values on a slice ``s`` of rows: evaluated on the rows' span and the smoother's margin
        around it (:meth:`~hmid.signal.Smoother.local`) rather than on whole segments, so that
        a long log's column is computed block by block."""
        rows = np.asarray(rows)
        if len(rows) == 0:
            return np.empty(0)
        lo, hi = int(rows[0]), int(rows[-1]) + 1
        if self.smoother is None:
            return np.asarray(values_of(slice(lo, hi)), dtype=float)[rows - lo]
        out = np.empty(len(rows))
        for start, stop, local in self._local_smoothers():
            if start < hi and stop > lo:
                first, last = np.searchsorted(rows, [start, stop])
                a, b = max(lo, start), min(hi, stop)
                span = smoothed_span(local, stop - start, _shifted(values_of, start), a - start,
                                     b - start)  # fmt: skip
                out[first:last] = span[rows[first:last] - a]
        return out

    def smooth_of(self, values_of: Callable[[slice], np.ndarray]) -> np.ndarray:
        """:meth:`smooth` of the values ``values_of(s)`` gives on each slice ``s`` of rows,
        computed block by block: they are never held whole."""
        if self.smoother is None:
            return np.asarray(values_of(slice(0, len(self))), dtype=float)
        out = np.empty(len(self))
        for start, stop, local in self._local_smoothers():
            out[start:stop] = smoothed_by_blocks(local, stop - start, _shifted(values_of, start))
        return out

    def _local_smoothers(self) -> list:
        def bound() -> list:  # each segment's (start, stop, local smoother), checked once
            t = self["t"]
            return [(a, b, local_smoother(self.smoother, t[a:b])) for a, b in self.bounds()]

        return self.derived(("local smoothers",), bound)

    def unit(self, channel: str) -> str:
        if channel not in self.units:
            raise ConfigError(
                f"no unit is known for channel {channel!r}; known: {list(self.units)}"
            )
        return self.units[channel]

    # -- derived sets -------------------------------------------------------------------------
    def with_columns(self, **columns: np.ndarray) -> Signals:
        versions = {**self._versions, **{c: next(_VERSIONS) for c in columns}}
        # taken as they are, not copied (pandas copies a bare array): a long log's new columns
        # are held once; the caller lets go of them (the frame's columns are read-only)
        index = self.frame.index
        shared = {c: pd.Series(v, index=index, copy=False) for c, v in columns.items()}
        return replace(
            self, frame=self.frame.assign(**shared), cache={}, versions=MappingProxyType(versions)
        )

    def with_roles(self, train: np.ndarray, validation: np.ndarray) -> Signals:
        usable = self.usable
        return self.with_columns(train=usable & train, validation=usable & validation)

    def trim(self, start_s: float = 0.0, end_s: float = 0.0) -> Signals:
        """No fitting or scoring within ``start_s`` of a segment's start or ``end_s`` of its end
        (a delay, a lead or a memory's warm-up reaches past them); the rows stay for the
        signals."""
        if start_s <= 0 and end_s <= 0:
            return self
        t = self["t"]
        keep = np.ones(len(self), dtype=bool)
        for rows in self.segments():
            keep[rows] = (t[rows] >= t[rows[0]] + start_s) & (t[rows] <= t[rows[-1]] - end_s)
        return self.with_columns(
            usable=self.usable & keep, train=self.train & keep, validation=self.validation & keep
        )

    def role_frame(self, role: str, columns: tuple[str, ...], keys: bool = True) -> pd.DataFrame:
        """The rows of ``role`` with ``columns`` (plus log and t unless ``keys`` is False), in
        order."""
        keep = self.rows(role)
        names = ["log", "t", *columns] if keys else list(columns)
        _noted(tuple((c, self._versions.get(c)) for c in names))
        return self.frame.loc[keep, names].reset_index(drop=True)


def _shifted(values_of: Callable[[slice], np.ndarray], start: int):
    """``values_of`` on slices counted from row ``start``."""
    return lambda s: values_of(slice(start + s.start, start + s.stop))
