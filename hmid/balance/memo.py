"""What is computed from a set of signals, kept for reuse: hmid's speed machinery in one object.

Profiling a relaxation time or screening the loop's candidates fits thousands of designs on the
same rows; their columns, transformed signals and Gram blocks are worth computing once. A
:class:`Memo` holds all of it, so that :class:`~hmid.balance.signals.Signals` stays plain data:

* **values** computed from one set (its segments, smoothers, a term's columns), per set, dropped
  with the set;
* **versions**: a number for each column of each set, new whenever a derived set replaces the
  column, so that a value computed from some columns is reused on any set that shares them (a
  sensor effect on P changes neither the columns nor the Gram blocks of the terms that read x);
* **recordings** of what a computation read (:meth:`Memo.recording`): the (column, version)
  pairs a value depends on;
* **keys** that name a term's columns in every Gram-block store.

A set and every set derived from it share one memo (``Signals.memo``); a new set from a table
starts a new one. Nothing here changes a number: a set without reuse computes the same values.
The one other cache of the balance is content-addressed (the memory arms, keyed by a digest of
the rows: :mod:`hmid.balance.operations`).
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

_T = TypeVar("_T")


class Memo:
    """The reusable values of a family of signal sets (one set and those derived from it)."""

    def __init__(self) -> None:
        self._versions = itertools.count()
        self._keys = itertools.count()
        self._recordings: list[set] = []
        self._stores: dict[int, dict] = {}

    # -- versions and recordings -------------------------------------------------------------
    def versions(self, columns: Iterable[str]) -> dict[str, int]:
        """A new version for each of ``columns``."""
        return {c: next(self._versions) for c in columns}

    def key(self) -> int:
        """A new key (an int hashes fast: it names a term's columns in every Gram-block store)."""
        return next(self._keys)

    @contextmanager
    def recording(self) -> Iterator[set]:
        """The (column, version) pairs read from any set of this memo inside the block (a
        missing column read as version None), those behind reused values included: what a
        value computed in the block depends on."""
        found: set = set()
        self._recordings.append(found)
        try:
            yield found
        finally:
            self._recordings.pop()

    def noted(self, deps: Iterable[tuple[str, int | None]]) -> None:
        """Record ``deps`` as read, in every open recording."""
        for found in self._recordings:
            found.update(deps)

    def __len__(self) -> int:
        """How many sets it keeps values for."""
        return len(self._stores)

    # -- values per set ----------------------------------------------------------------------
    def store(self, owner: object) -> dict:
        """The values kept for the set ``owner``; dropped when the set is."""
        found = self._stores.get(id(owner))
        if found is None:
            found = self._stores[id(owner)] = {}
            weakref.finalize(owner, self._stores.pop, id(owner), None)
        return found

    def derived(self, owner: object, key: object, compute: Callable[[], _T]) -> _T:
        """``compute()``, once per set and ``key``; what it read is noted again on every reuse,
        so that a recording around the caller sees it."""
        store = self.store(owner)
        found = store.get(key)
        if found is None:
            with self.recording() as deps:
                value = compute()
            found = store[key] = (value, frozenset(deps))
        self.noted(found[1])
        return found[0]

    def inherit(
        self, owner: object, other: object, keys: Iterable[object], holds: Callable[[Any], bool]
    ) -> None:
        """Give the set ``other`` the values :meth:`derived` kept for ``owner`` under ``keys``
        whose reads ``holds`` for it (``holds(deps)``): a set derived by new roles keeps its
        segments and smoothers rather than finding them again."""
        source = self._stores.get(id(owner), {})
        for key in keys:
            found = source.get(key)
            if found is not None and holds(found[1]):
                self.store(other).setdefault(key, found)

    @contextmanager
    def scoped(self, owner: object) -> Iterator[None]:
        """What is kept for ``owner`` inside the block is dropped after it (entries appended to
        a kept list are cut back): a candidate's transformed signals and their columns are of no
        use to the next, and the loop would otherwise hold gigabytes of them."""
        store = self.store(owner)
        before = {key: len(v) if isinstance(v, list) else None for key, v in store.items()}
        try:
            yield
        finally:
            for key in [key for key in store if key not in before]:
                del store[key]
            for key, length in before.items():
                if length is not None:
                    del store[key][length:]

    def __getstate__(self) -> Any:  # a pickled set starts afresh where it is loaded
        raise TypeError("a Memo is this process's: pickle the signals, not their memo")
