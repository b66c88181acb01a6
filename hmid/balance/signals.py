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
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, TypeVar

import numpy as np
import pandas as pd

from hmid.balance.memo import Memo
from hmid.errors import ConfigError
from hmid.signal.blocks import local_smoother, smoothed_by_blocks, smoothed_span

if TYPE_CHECKING:
    from hmid.signal import Smoother

_T = TypeVar("_T")

REQUIRED = ("log", "segment", "t", "target", "usable", "train", "validation")

#: What :class:`Signals` finds from its time base alone (the segments and the time column): a
#: derived set that keeps both keeps these (:meth:`Memo.inherit`)
_TIME_BASE = (("segments",), ("smoothers",), ("local smoothers",))


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
    #: what is computed from these rows and the sets derived from them (:mod:`hmid.balance.memo`)
    memo: Memo = field(default_factory=Memo, compare=False, repr=False)
    # each column's version (from the memo): a derived set shares those of the columns it keeps
    versions: Mapping[str, int] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        missing = [c for c in (*REQUIRED, *self.channels) if c not in self.frame.columns]
        if missing:
            raise ValueError(f"Signals needs columns {missing}")
        if (self.frame["train"] & self.frame["validation"]).any():
            raise ValueError("a row cannot be both training and held-out")
        object.__setattr__(self, "units", MappingProxyType(dict(self.units)))
        if self.versions is None:
            versions = self.memo.versions(self.frame.columns)
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

    # read-only mappings do not pickle; the stage cache pickles signals. The memo and its
    # versions are this process's: a loaded set starts a new memo
    def __getstate__(self) -> dict:
        state = self.__dict__ | {"units": dict(self.units)}
        return {k: v for k, v in state.items() if k not in ("memo", "versions")}

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, MappingProxyType(value) if name == "units" else value)
        memo = Memo()
        object.__setattr__(self, "memo", memo)
        object.__setattr__(self, "versions", MappingProxyType(memo.versions(self.frame.columns)))

    @property
    def _versions(self) -> Mapping[str, int]:
        """:attr:`versions`, which ``__post_init__`` sets where none is given."""
        assert self.versions is not None
        return self.versions

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def cache(self) -> dict:
        """This set's values in its memo (columns, transformed signals, Gram blocks)."""
        return self.memo.store(self)

    def __getitem__(self, column: str) -> np.ndarray:
        versions = self._versions
        if column in versions:
            self.memo.noted(((column, versions[column]),))
        # pandas' column lookup costs ~0.2 ms on an index of strings; profiling reads thousands
        cache = self.cache
        found = cache.get(("array", column))
        if found is None:
            found = cache[("array", column)] = self.frame[column].to_numpy()
        return found

    def __contains__(self, column: str) -> bool:
        self.memo.noted(((column, self._versions.get(column)),))
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
        """``compute()``, once per signals and ``key`` (:meth:`Memo.derived`)."""
        return self.memo.derived(self, key, compute)

    @contextmanager
    def scoped(self) -> Iterator[Signals]:
        """What is kept for this set inside the block is dropped after it
        (:meth:`Memo.scoped`)."""
        with self.memo.scoped(self):
            yield self

    def reads_same(self, deps) -> bool:
        """Whether every (column, version) of ``deps`` (from :meth:`Memo.recording`) holds
        here."""
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
            smoothed_by_blocks(local, stop - start, _shifted(values_of, start), out=out[start:stop])
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
        versions = {**self._versions, **self.memo.versions(columns)}
        # taken as they are, not copied (pandas copies a bare array): a long log's new columns
        # are held once; the caller lets go of them (the frame's columns are read-only)
        index = self.frame.index
        shared = {c: pd.Series(v, index=index, copy=False) for c, v in columns.items()}
        out = replace(self, frame=self.frame.assign(**shared), versions=MappingProxyType(versions))
        # its segments and smoothers, where it keeps the time base (a long log's median step is
        # a difference of its whole time column: 80 MB at 10 M rows, taken once)
        self.memo.inherit(self, out, _TIME_BASE, out.reads_same)
        return out

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
        self.memo.noted(tuple((c, self._versions.get(c)) for c in names))
        # column by column: ``frame.loc[keep, names]`` holds a second copy of a column's rows
        # while it builds the table (a long log's training rows are ~70 MB a column)
        return pd.DataFrame({c: self.frame[c].array[keep] for c in names}, copy=False)


def _shifted(values_of: Callable[[slice], np.ndarray], start: int):
    """``values_of`` on slices counted from row ``start``."""
    return lambda s: values_of(slice(start + s.start, start + s.stop))
