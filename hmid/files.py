"""Safe file output: atomic writes and never-overwrite output folders.

A file is written to a temporary sibling and moved into place with ``os.replace``, so a crash
leaves either the old file or the complete new one, never a half-written file that looks complete.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from hmid.errors import HmidError, HmidWarning


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it replaces ``path`` atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as err:  # name the file meant, not a random temporary name
        raise OSError(err.errno, err.strerror, str(path)) from err
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except OSError as err:
        if err.filename not in (None, tmp):
            raise
        raise OSError(err.errno, err.strerror, str(path)) from err  # e.g. a full disk
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


@contextmanager
def held(lock_path: str | Path, waiting: str) -> Iterator[None]:
    """Hold the file lock ``lock_path`` for the block; if another process holds it, say
    ``waiting`` (a one-line :class:`~hmid.errors.HmidWarning`) and wait for it."""
    lock = FileLock(lock_path)
    try:
        lock.acquire(timeout=0)
    except Timeout:
        warnings.warn(waiting, HmidWarning, stacklevel=4)
        lock.acquire()
    try:
        yield
    finally:
        lock.release()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text(path: str | Path, text: str) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_json(path: str | Path, data: Any) -> Path:
    return write_text(path, json.dumps(data, indent=2, sort_keys=False, allow_nan=True) + "\n")


def sha256(path: str | Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fresh_dir(path: str | Path, *, replace: bool = False) -> Path:
    """Create an empty output folder; an existing non-empty one is an error unless ``replace``."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise HmidError(f"{path}: exists and is not a folder; choose a folder for the output")
    if path.exists() and any(path.iterdir()) and not replace:
        raise HmidError(
            f"{path}: output folder exists and is not empty; choose another folder "
            f"(earlier results are never overwritten) or pass --replace to regenerate it"
        )
    path.mkdir(parents=True, exist_ok=True)
    return path
