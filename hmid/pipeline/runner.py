"""A small runner that wires pure stage functions and caches their results by content hash.

A stage's cache key hashes its name, the JSON of what it depends on in the config (its
``depends`` callable; the load stage includes the input files' SHA-256), the keys of its upstream
stages, and a fingerprint of hmid's own source code. Changing a config section or an input file
recomputes that stage and everything downstream of it; anything else is read back from the cache.
Cache files are written atomically, so an interrupted run never leaves a truncated entry.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import pickle
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

from hmid.files import atomic_path


@dataclass(frozen=True)
class Stage:
    """One pipeline step: ``fn(config, **upstream) -> artifact``, pure apart from reading inputs."""

    name: str
    fn: Callable[..., Any]
    inputs: tuple[str, ...] = ()
    depends: Callable[[Any], Any] = lambda config: None


@cache
def code_fingerprint() -> str:
    """SHA-256 over hmid's source files: a code change invalidates every cached stage."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


@dataclass
class StageRecord:
    key: str
    cached: bool
    wall_s: float


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

    def run(self, stages: Sequence[Stage], config: Any) -> dict[str, Any]:
        """Run ``stages`` (each after its inputs); returns every artifact by stage name."""
        artifacts: dict[str, Any] = {}
        for stage in stages:
            missing = [name for name in stage.inputs if name not in artifacts]
            if missing:
                raise ValueError(f"stage {stage.name!r} needs {missing}, not produced before it")
            key = self._key(stage, config, [self.records[n].key for n in stage.inputs])
            path = self.cache_dir / f"{stage.name}-{key[:20]}.pkl"
            start = time.perf_counter()
            if path.is_file() and not self.force:
                with open(path, "rb") as handle:
                    artifacts[stage.name] = pickle.load(handle)
                cached = True
            else:
                upstream = {name: artifacts[name] for name in stage.inputs}
                parameters = inspect.signature(stage.fn).parameters
                if "workdir" in parameters:
                    upstream["workdir"] = self.cache_dir  # for resumable side work (MCMC chains)
                if "force" in parameters:
                    upstream["force"] = self.force
                artifacts[stage.name] = stage.fn(config, **upstream)
                with atomic_path(path) as tmp, open(tmp, "wb") as handle:
                    pickle.dump(artifacts[stage.name], handle, protocol=pickle.HIGHEST_PROTOCOL)
                cached = False
            self.records[stage.name] = StageRecord(key, cached, time.perf_counter() - start)
        return artifacts
