"""Checksummed cache entries: a pickle followed by its SHA-256, verified before it is unpickled.

An entry is ``<pickle bytes><MAGIC><32-byte SHA-256 of the pickle bytes>``, written atomically.
Reading checks the trailer first and unpickles only bytes whose digest matches, so an altered,
truncated, empty or foreign file is a :class:`StaleEntry` (the caller recomputes), never a
silently wrong result and never a traceback. Writing hashes the pickle as it streams to disk:
a large artifact is not held twice in memory.
"""

from __future__ import annotations

import hashlib
import pickle
from pathlib import Path
from typing import Any, BinaryIO

from hmid.files import atomic_path

MAGIC = b"HMID-SHA256-1"
_TRAILER = len(MAGIC) + 32
_BLOCK = 1 << 22


class StaleEntry(Exception):
    """A cache entry that cannot be trusted; ``str()`` says why in a few words."""


class _HashingWriter:
    """A file-like sink that hashes what it writes."""

    def __init__(self, handle: BinaryIO) -> None:
        self.handle, self.digest = handle, hashlib.sha256()

    def write(self, data) -> int:
        self.digest.update(data)
        return self.handle.write(data)


def write_entry(path: Path, artifact: Any) -> None:
    """Pickle ``artifact`` to ``path`` (atomically) with its checksum as a trailer."""
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        sink = _HashingWriter(handle)
        pickle.dump(artifact, sink, protocol=pickle.HIGHEST_PROTOCOL)
        handle.write(MAGIC + sink.digest.digest())


def read_entry(path: Path) -> Any:
    """The artifact stored at ``path``; :class:`StaleEntry` if it is missing a valid checksum."""
    try:
        size = path.stat().st_size
        with open(path, "rb") as handle:
            if size < _TRAILER + 1:
                raise StaleEntry("is empty or truncated" if size else "is empty")
            handle.seek(size - _TRAILER)
            trailer = handle.read(_TRAILER)
            if not trailer.startswith(MAGIC):
                raise StaleEntry("has no checksum (truncated, altered or from an older hmid)")
            handle.seek(0)
            digest, left = hashlib.sha256(), size - _TRAILER
            while left:
                block = handle.read(min(_BLOCK, left))
                if not block:
                    raise StaleEntry("is truncated")
                digest.update(block)
                left -= len(block)
            if digest.digest() != trailer[len(MAGIC) :]:
                raise StaleEntry("does not match its checksum (altered or damaged)")
            handle.seek(0)
            return pickle.load(handle)
    except StaleEntry:
        raise
    except OSError as err:
        raise StaleEntry(f"cannot be read ({err.strerror or err})") from err
    except Exception as err:  # a checksummed pickle that fails to load: a class changed shape
        raise StaleEntry(f"does not unpickle ({type(err).__name__})") from err
