"""Run folders ``results/<experiment>/<run-id>/``: created once, never overwritten, with a manifest.

The manifest records what is needed to replay a run: the resolved config, a SHA-256 of every
input file, the git commit (and whether the tree was dirty), package versions, the seed, and
start/end times with per-stage wall times. It is written when the folder is made (``status:
running``) and again at the end (``complete``, or ``failed`` with the one-line error), so a folder
is never half-made without saying so. Every command opens its folder with :func:`open_run`.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import platform
import re
import shutil
import socket
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from hmid.errors import HmidError
from hmid.files import sha256, write_json, write_text

_RUN_ID = re.compile(r"^\d{8}T\d{6}Z-[0-9a-f]{8}(-\d+)?$")

PACKAGES = ("hmid", "numpy", "scipy", "pandas", "jax", "pysindy", "emcee", "statsmodels", "pint",
            "pydantic", "matplotlib")  # fmt: skip


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def git_state(cwd: Path | None = None) -> dict[str, object]:
    """Commit hash and dirty flag of hmid's own source tree (None outside git)."""
    cwd = cwd or Path(__file__).resolve().parent
    try:
        run = lambda *a: subprocess.run(  # noqa: E731
            ["git", *a], cwd=cwd, capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        return {"commit": run("rev-parse", "HEAD"), "dirty": bool(run("status", "--porcelain"))}
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}


def versions() -> dict[str, str | None]:
    out: dict[str, str | None] = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def new_run_dir(results: Path, experiment: str, config_json: str) -> Path:
    """A new, empty run folder named ``<UTC time>-<config hash>`` (suffixed if taken)."""
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%SZ")
    digest = hashlib.sha256(config_json.encode()).hexdigest()[:8]
    base = Path(results) / experiment
    base.mkdir(parents=True, exist_ok=True)
    for k in range(1000):
        run_dir = base / (f"{stamp}-{digest}" + (f"-{k}" if k else ""))
        try:
            run_dir.mkdir()  # atomic: two runs never share a folder
            return run_dir
        except FileExistsError:
            continue
    raise FileExistsError(f"{base}: could not create a fresh run folder")


@dataclass
class Manifest:
    """Provenance of one run; :meth:`stage` times a stage, :meth:`write` saves manifest.json."""

    run_dir: Path
    config: dict
    seed: int
    inputs: dict[str, str] = field(default_factory=dict)
    stages: dict[str, float] = field(default_factory=dict)
    work: dict[str, float] = field(default_factory=dict)  # started stages: their work's time
    cache: dict[str, bool | None] = field(default_factory=dict)  # stage -> read from the cache
    reused: dict[str, str] = field(default_factory=dict)  # model -> stored work it read back
    started: str = field(default_factory=_now)
    status: str = "running"
    error: str | None = None

    def add_input(self, path: Path) -> None:
        self.inputs[str(path)] = sha256(path)

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        start = time.perf_counter()
        try:
            yield
        finally:
            self.stages[name] = self.stages.get(name, 0.0) + time.perf_counter() - start

    def write(self) -> Path:
        return write_json(
            self.run_dir / "manifest.json",
            {
                "config": self.config,
                "seed": self.seed,
                "inputs_sha256": self.inputs,
                "git": git_state(),
                "versions": versions(),
                "status": self.status,
                "error": self.error,
                "started": self.started,
                "process": {"host": socket.gethostname(), "pid": os.getpid()},
                "finished": None if self.status == "running" else _now(),
                "stage_wall_s": {k: round(v, 4) for k, v in self.stages.items()},
                "stage_work_s": {k: round(v, 4) for k, v in self.work.items()},
                "stage_cached": self.cache,
                "reused": self.reused,
            },
        )


def config_json(config) -> str:
    """Canonical JSON of a pydantic config (hash input and manifest entry)."""
    # where the config file sits (base_dir) is provenance, not content: it must not change the id
    exclude = {"base_dir"} if "base_dir" in type(config).model_fields else None
    return json.dumps(config.model_dump(mode="json", exclude=exclude), sort_keys=True)


@dataclass
class RunFolder:
    """An open run folder: its path, manifest and provenance (for the report)."""

    path: Path
    manifest: Manifest
    config_path: Path

    def provenance(self, **extra: str) -> dict[str, str]:
        git = git_state()
        return {
            "config": str(self.config_path),
            "config sha256": self.manifest.inputs[str(self.config_path)],
            "git commit": f"{git['commit']}{' (dirty)' if git['dirty'] else ''}",
            "seed": str(self.manifest.seed),
            "run folder": str(self.path),
            **extra,
            **{f"version {k}": str(v) for k, v in versions().items()},
        }


@contextmanager
def open_run(
    results: Path,
    name: str,
    config_path: Path,
    resolved: str,
    seed: int,
    inputs: list[Path],
    copy_as: str = "config.yaml",
) -> Iterator[RunFolder]:
    """A new run folder holding the config file (as ``copy_as``) and a manifest that says
    ``running``; it says ``complete`` when the block ends, ``failed`` (with the error) when it
    raises or is interrupted."""
    path = new_run_dir(Path(results), name, resolved).resolve()
    manifest = Manifest(path, json.loads(resolved), seed)
    for item in [Path(config_path), *inputs]:
        manifest.add_input(item)
    write_text(path / copy_as, Path(config_path).read_text(encoding="utf-8"))
    manifest.write()
    try:
        yield RunFolder(path, manifest, Path(config_path))
    except BaseException as err:
        manifest.status = "failed"
        said = " ".join(str(err).split())
        interrupted = isinstance(err, KeyboardInterrupt)
        manifest.error = said or ("interrupted (Ctrl-C)" if interrupted else type(err).__name__)
        manifest.write()
        raise
    manifest.status = "complete"
    manifest.write()


@dataclass(frozen=True)
class RunEntry:
    """One run folder as ``hmid runs`` lists it."""

    path: Path
    status: str  # complete | failed | running | stale (its process is gone) | no manifest
    started: str | None
    error: str | None


def _status(manifest: dict) -> str:
    status = manifest.get("status") or "no status"
    process = manifest.get("process") or {}
    if status == "running" and process.get("host") == socket.gethostname():
        try:
            os.kill(int(process["pid"]), 0)
        except ProcessLookupError:
            return "stale"  # killed without a word (SIGKILL, power): it will never finish
        except (OSError, KeyError, TypeError, ValueError):
            pass
    return status


def list_runs(root: Path) -> list[RunEntry]:
    """Every run folder under ``root`` (a results root, an experiment's or a sweep's folder),
    oldest first."""
    root = Path(root)
    if not root.is_dir():
        raise HmidError(f"{root}: not a folder of results; give the --results root or a subfolder")
    folders = {p.parent for p in root.rglob("manifest.json")}
    folders |= {d for d in root.rglob("*") if _RUN_ID.match(d.name) and d.is_dir()}
    entries = []
    for folder in folders:
        if ".cache" in folder.relative_to(root).parts:
            continue
        manifest_path = folder / "manifest.json"
        if not manifest_path.is_file():
            entries.append(RunEntry(folder, "no manifest", None, None))
            continue
        try:
            manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            entries.append(RunEntry(folder, "unreadable manifest", None, None))
            continue
        entries.append(
            RunEntry(folder, _status(manifest), manifest.get("started"), manifest.get("error"))
        )
    return sorted(entries, key=lambda e: (e.started or "", str(e.path)))


def remove_runs(entries: list[RunEntry]) -> list[Path]:
    """Delete the folders of ``entries`` (the caller picks failed or stale ones)."""
    for entry in entries:
        shutil.rmtree(entry.path)
    return [entry.path for entry in entries]
