"""The free run's traced programs kept on disk (``jax.export``), beside JAX's compiled ones.

JAX's persistent cache (:mod:`hmid.pipeline.compilation`) keeps a program once compiled, but a
new process still traces it before it can look it up: for the free run's two programs (diffrax's
error-controlled solve and the band's fixed steps) that was ~2 s of the demo's free-run stage,
more than running its six models' error-controlled runs. So each program is exported (its
StableHLO, :func:`jax.export.export`) the first time it is traced for a set of argument shapes,
written beside the compiled programs (JAX's own serialisation, :meth:`Exported.serialize`, in a
checksummed entry as the stage cache's), and read back by the next process, which then calls it
without tracing it.

Every call goes through the exported program, whether just traced or read back, so a run gives
the same numbers either way. A file is keyed by the program's name, its
:class:`~hmid.portable.freerun.program.Shape`, its arguments' shapes and dtypes, the platform,
the source of the modules that trace it and the versions of the libraries that do; one that
cannot be read is traced again and rewritten. The file's name holds the build (the sources,
the libraries and the platform) apart from the rest, so that when a program is written, the
files of any other build unused for a day (:data:`UNUSED_S`; a file read is marked used) are
removed: an upgrade leaves no dead programs behind. Without a compilation-cache folder (tests,
a notebook) the programs are jitted as they are, and nothing is written.
"""

from __future__ import annotations

import hashlib
import os
import time
from collections.abc import Callable
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from hmid.pipeline.cache import StaleEntry, read_entry, write_entry

#: The modules whose source a traced program depends on (besides the libraries)
SOURCES = ("integrator.py", "program.py")
LIBRARIES = ("jax", "jaxlib", "diffrax", "equinox")


def stored(fn: Callable[..., Any], name: str, shape: object,
           folder: Path | None = None) -> Callable[..., Any]:  # fmt: skip
    """``fn`` jitted; with a compilation-cache folder set (or ``folder``), exported and kept
    there (see the module's docstring)."""
    import jax

    folder = folder or jax.config.jax_compilation_cache_dir  # type: ignore[attr-defined]
    if not folder:
        return jax.jit(fn)
    return _Stored(fn, name, repr(shape), Path(folder) / "freerun-programs")


class _Stored:
    """``fn``, exported once per set of argument shapes, called through the export."""

    def __init__(self, fn: Callable[..., Any], name: str, shape: str, folder: Path) -> None:
        self.fn, self.name, self.shape, self.folder = fn, name, shape, folder
        self.calls: dict[tuple, Callable[..., Any]] = {}

    def __call__(self, *args):
        # the arguments' shapes and dtypes, read off the arrays (a free run calls its programs
        # hundreds of times: building JAX's shape structs each time, and copying a JAX array
        # back to read its dtype, cost a tenth of the calls' time)
        key = tuple((np.shape(a), _dtype(a).str) for a in _leaves(args))
        call = self.calls.get(key)
        if call is None:
            import jax

            call = self.calls[key] = jax.jit(self._exported(args, key).call)
        return call(*args)

    def _exported(self, args, key):
        import jax
        from jax import export

        build = _build()
        path = self.folder / f"{self.name}-{build}-{_digest(self.shape, key)}.exported"
        try:
            exported = export.deserialize(bytearray(read_entry(path)))
        except StaleEntry:  # none yet, or damaged: traced again, and rewritten
            pass
        else:
            _touch(path)  # in use: another build's pruning leaves it
            return exported
        exported = export.export(jax.jit(self.fn))(*jax.tree.map(np.asarray, args))
        try:
            # no derivatives: a free run is never differentiated, and their closures do not
            # serialise
            write_entry(path, bytes(exported.serialize(vjp_order=0)))
            _prune(self.folder, build)
        except OSError:  # a folder that cannot be written: traced in every process, as before
            pass
        return exported


#: Another build's program unused for this long is removed (a day: two checkouts or
#: environments sharing a results folder keep each other's programs while both are in use)
UNUSED_S = 86_400.0


def _touch(path: Path) -> None:
    """Mark ``path`` used now (its modification time), where the folder allows."""
    try:
        os.utime(path)
    except OSError:
        pass


def _prune(folder: Path, build: str) -> None:
    """Remove the programs of builds other than ``build`` unused for :data:`UNUSED_S`: after
    an upgrade, no process of the old build reads them again."""
    now = time.time()
    for other in folder.glob("*.exported"):
        try:
            if f"-{build}-" not in other.name and now - other.stat().st_mtime > UNUSED_S:
                other.unlink()
        except OSError:  # gone already (another process pruned it), or not ours to remove
            pass


def _leaves(args) -> list:
    """The arrays of ``args``, in order (tuples of them flattened: a program's arrays)."""
    out = []
    for a in args:
        if isinstance(a, (tuple, list)):
            out += _leaves(a)
        else:
            out.append(a)
    return out


def _dtype(a) -> np.dtype:
    """An argument's dtype without copying it (a JAX array's own; a number's as numpy reads it)."""
    dtype = getattr(a, "dtype", None)
    return np.dtype(dtype) if dtype is not None else np.asarray(a).dtype


def _digest(shape: str, key: tuple) -> str:
    """A program's shape and its arguments' shapes and dtypes, hashed."""
    return hashlib.sha256(f"{shape} {key}".encode()).hexdigest()[:16]


@lru_cache(maxsize=1)
def _build() -> str:
    """What every program of this process is traced by, hashed: the platform, the source of
    :data:`SOURCES` and the versions of :data:`LIBRARIES` (see the module's docstring)."""
    import jax

    digest = hashlib.sha256(jax.default_backend().encode())
    here = Path(__file__).parent
    for source in SOURCES:
        digest.update((here / source).read_bytes())
    for library in LIBRARIES:
        try:
            digest.update(f"{library}=={metadata.version(library)}".encode())
        except metadata.PackageNotFoundError:
            digest.update(f"{library} absent".encode())
    return digest.hexdigest()[:12]
