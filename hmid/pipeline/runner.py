"""A small runner that wires pure stage functions and caches their results by content hash.

A stage's cache key hashes its name, the JSON of what it depends on in the config (its
``depends`` callable; the load stage includes the input files' SHA-256), the keys of its upstream
stages, a fingerprint of the source code (``hmid`` and the stage wiring in ``pipelines``) and
the versions of the libraries that compute. Changing any of them recomputes that stage and
everything downstream of it; anything else is read back from the cache.

Entries carry a checksum (:mod:`hmid.pipeline.cache`): an altered, truncated or unreadable entry
is recomputed with a one-line note, never used. A stage being computed holds a lock on its entry,
so a second run with the same key waits and then reads the first run's result.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import json
import time
import warnings
from collections.abc import Callable, Collection, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from functools import cache
from importlib import metadata
from pathlib import Path
from typing import Any

from hmid.errors import HmidWarning
from hmid.files import held
from hmid.pipeline.cache import StaleEntry, read_entry, write_entry

# what computes a stage's numbers: a new version of any of them recomputes the cache
COMPUTING = ("numpy", "scipy", "pandas", "jax", "jaxlib", "pysindy", "emcee", "statsmodels",
             "scikit-learn", "pint", "h5py")  # fmt: skip


@dataclass(frozen=True)
class Stage:
    """One pipeline step: ``fn(config, **upstream) -> artifact``, pure apart from reading inputs.

    ``store=False`` for stages whose artifact is the data itself (loaded, smoothed, split): they
    are cheap to redo and a cache of them would copy every log several times over.

    ``started=True`` for a stage whose work goes on beside the stages after it (handed to a
    worker, :mod:`hmid.workers`): ``fn`` then returns a :class:`Pending`, whose ``result`` the
    runner calls when a later stage reads the artifact, or once the last stage is done, and
    whose ``cancel`` it calls where a stage in between fails. Its time is what the run spent in
    the two calls (the worker's is not the run's to wait for).
    """

    name: str
    fn: Callable[..., Any]
    inputs: tuple[str, ...] = ()
    depends: Callable[[Any], Any] = lambda config: None
    store: bool = True
    started: bool = False


@cache
def code_fingerprint() -> str:
    """SHA-256 over the source of ``hmid`` and ``pipelines`` and the computing libraries'
    versions: a change to any of them invalidates every cached stage."""
    digest = hashlib.sha256()
    for package in ("hmid", "pipelines"):
        spec = importlib.util.find_spec(package)
        if spec is None or not spec.submodule_search_locations:
            digest.update(f"{package}: absent".encode())
            continue
        root = Path(next(iter(spec.submodule_search_locations))).resolve()
        for path in sorted(root.rglob("*.py")):
            digest.update(f"{package}/{path.relative_to(root).as_posix()}".encode())
            digest.update(path.read_bytes())
    for name in COMPUTING:
        try:
            digest.update(f"{name}=={metadata.version(name)}".encode())
        except metadata.PackageNotFoundError:
            digest.update(f"{name} absent".encode())
    return digest.hexdigest()


@dataclass
class StageRecord:
    key: str
    cached: bool | None  # None: a stage that is never stored (the data stages)
    wall_s: float  # the run's own time in the stage
    work_s: float | None = None  # a started stage's: how long its work ran, wherever it ran


@dataclass(frozen=True)
class Pending:
    """What a started stage (``Stage.started``) returns: ``result()`` waits for its work and
    gives the artifact; ``cancel()`` drops the work where the run fails before it is read;
    ``work_s()``, once the result is in, how long the work ran (in a worker, mostly while the
    run did other things: the stage's wall time alone would say it cost nothing)."""

    result: Callable[[], Any]
    cancel: Callable[[], None] = lambda: None
    work_s: Callable[[], float | None] = lambda: None


@dataclass
class _Started:
    """A stage begun whose artifact is still to come (``Stage.started``)."""

    stage: Stage
    pending: Pending
    key: str
    path: Path | None  # its cache entry (None: not stored)
    lock: ExitStack  # the entry's lock, held until the artifact is written
    seconds: float  # the run's time in the stage so far


@dataclass
class Runner:
    """Runs stages in order; ``force`` ignores (and refreshes) the cache."""

    cache_dir: Path
    force: bool = False
    records: dict[str, StageRecord] = field(default_factory=dict)

    def _key(self, stage: Stage, config: Any, upstream_keys: Sequence[str]) -> str:
        payload = json.dumps(
            {
                "stage": stage.name,
                "depends": stage.depends(config),
                "upstream": list(upstream_keys),
                "code": code_fingerprint(),
            },
            sort_keys=True,
            default=str,
        )
        return hashlib.sha256(payload.encode()).hexdigest()

    def run(
        self,
        stages: Sequence[Stage],
        config: Any,
        *,
        keep: Collection[str] | None = None,
        before: Mapping[str, Callable[[], object]] | None = None,
        progress: Any = None,
    ) -> dict[str, Any]:
        """Run ``stages`` (each after its inputs); returns every artifact by stage name, or only
        those named in ``keep``: the others are let go after their last reader, so that a long
        log is not held as loaded, as smoothed and as signals at once. ``before[name]()`` is
        called before stage ``name`` (to have a worker import what a later stage needs);
        ``progress`` (a :class:`hmid.progress.Progress`) hears of each stage's start and end."""
        before = before or {}
        artifacts: dict[str, Any] = {}
        last_read = {s.name: i for i, s in enumerate(stages)}
        for i, stage in enumerate(stages):
            for name in stage.inputs:
                last_read[name] = i
        started: dict[str, _Started] = {}
        try:
            for i, stage in enumerate(stages):
                for name in [n for n in stage.inputs if n in started]:
                    artifacts[name] = self._finish(started.pop(name), progress)
                missing = [name for name in stage.inputs if name not in artifacts]
                if missing:
                    raise ValueError(
                        f"stage {stage.name!r} needs {missing}, not produced before it"
                    )
                if stage.name in before:
                    before[stage.name]()
                begun = self._stage(stage, config, artifacts, progress)
                if begun is not None:
                    started[stage.name] = begun
                if keep is not None:
                    for name in [n for n in artifacts if n not in keep and last_read[n] <= i]:
                        del artifacts[name]
            for name in list(started):
                found = self._finish(started.pop(name), progress)
                if keep is None or name in keep:
                    artifacts[name] = found
        finally:
            for begun in started.values():  # a later stage failed: its work and locks go
                begun.pending.cancel()
                begun.lock.close()
        return artifacts

    def _stage(self, stage: Stage, config: Any, artifacts: dict[str, Any],
               progress: Any) -> _Started | None:  # fmt: skip
        """Run (or read back) ``stage`` into ``artifacts``; a stage begun (``Stage.started``)
        whose artifact is still to come is returned instead."""
        if progress is not None:
            progress.started(stage.name)
        key = self._key(stage, config, [self.records[n].key for n in stage.inputs])
        path = self.cache_dir / f"{stage.name}-{key[:20]}.pkl"
        start = time.perf_counter()
        found = None
        with ExitStack() as lock:
            if stage.store:
                self.cache_dir.mkdir(parents=True, exist_ok=True)
                lock.enter_context(_locked(path, f"stage {stage.name!r}"))
                found = None if self.force else self._read(stage, path)
            if found is not None:
                artifacts[stage.name] = found[0]
            else:
                computed = self._compute(stage, config, artifacts)
                if stage.started:  # the lock is held until its artifact is written
                    seconds = time.perf_counter() - start
                    return _Started(stage, computed, key, path if stage.store else None,
                                    lock.pop_all(), seconds)  # fmt: skip
                artifacts[stage.name] = computed
                if stage.store:
                    # labelled with its stage: an entry copied over another's is caught
                    write_entry(path, (stage.name, computed))
        cached = (found is not None) if stage.store else None
        self._record(stage.name, StageRecord(key, cached, time.perf_counter() - start), progress)
        return None

    def _finish(self, begun: _Started, progress: Any) -> Any:
        """The artifact of a stage begun (waiting for the work it handed out), written to the
        cache; its lock let go."""
        start = time.perf_counter()
        with begun.lock:
            found = begun.pending.result()
            if begun.path is not None:
                write_entry(begun.path, (begun.stage.name, found))
        seconds = begun.seconds + time.perf_counter() - start
        cached = False if begun.path is not None else None
        record = StageRecord(begun.key, cached, seconds, begun.pending.work_s())
        self._record(begun.stage.name, record, progress)
        return found

    def _record(self, name: str, record: StageRecord, progress: Any) -> None:
        self.records[name] = record
        if progress is not None:
            progress.done(name, record.wall_s, record.cached)

    def _compute(self, stage: Stage, config: Any, artifacts: dict[str, Any]) -> Any:
        upstream = {name: artifacts[name] for name in stage.inputs}
        parameters = inspect.signature(stage.fn).parameters
        if "workdir" in parameters:
            upstream["workdir"] = self.cache_dir  # for resumable side work (MCMC chains)
        if "force" in parameters:
            upstream["force"] = self.force
        return stage.fn(config, **upstream)

    @staticmethod
    def _read(stage: Stage, path: Path) -> tuple[Any] | None:
        """``(artifact,)`` from a valid entry; None (with a note if one was there) otherwise."""
        if not path.exists():
            return None
        try:
            entry = read_entry(path)
            if not (isinstance(entry, tuple) and len(entry) == 2 and entry[0] == stage.name):
                held = entry[0] if isinstance(entry, tuple) and entry else type(entry).__name__
                raise StaleEntry(f"holds {held!r}, not stage {stage.name!r}'s result")
            return (entry[1],)
        except StaleEntry as why:
            warnings.warn(
                f"{path}: cache entry {why}; recomputing stage {stage.name!r}",
                HmidWarning,
                stacklevel=3,
            )
            return None


def _locked(path: Path, what: str):
    """Hold ``locks/<name>.lock`` beside ``path`` while ``what`` is computed; a second run
    waits (and says so)."""
    (path.parent / "locks").mkdir(exist_ok=True)
    return held(
        path.parent / "locks" / f"{path.name}.lock",
        f"{path}: another run is computing {what}; waiting for it (its result is reused)",
    )
