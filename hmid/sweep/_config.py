"""The sweep config: one base experiment, the overrides of each run, and where the runs execute.

A sweep file names a ``base`` experiment config and either ``runs`` (an explicit list of override
mappings) or ``grid`` (dotted keys mapped to value lists; every combination is one run, the first
key varying slowest). An override key is a dotted path into the experiment config, with list
positions as numbers: ``denoise.smoother.window_s``, ``logs.0.path``, ``models``. The value
replaces whatever is at that key (mappings are not merged: give the leaf's key to change one
value). Paths are relative to the file that names them: the base's log paths to the base's folder,
log paths given in the sweep to the sweep file's folder.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from hmid.config import load_yaml_model
from hmid.errors import ConfigError

_Runs = Annotated[tuple[dict[str, Any], ...], Field(min_length=1)]
_Grid = Annotated[dict[str, Annotated[list[Any], Field(min_length=1)]], Field(min_length=1)]
_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.([A-Za-z_][A-Za-z0-9_]*|[0-9]+))*$")


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ExecutorSection(_Frozen):
    """Where runs execute: a local process pool, or a Dask cluster (``address``: its scheduler).

    ``kind: dask`` without an address starts a local cluster of ``workers`` processes for the
    sweep. ``workers`` defaults to one per CPU core; a remote cluster decides its own.
    """

    kind: Literal["process", "dask"] = "process"
    workers: Annotated[int, Field(ge=1)] | None = None
    address: Annotated[str, Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> ExecutorSection:
        if self.address is not None and self.kind != "dask":
            raise ValueError("an address names a Dask scheduler: it needs kind 'dask'")
        if self.address is not None and self.workers is not None:
            raise ValueError(
                f"the cluster at {self.address} has its own workers: leave 'workers' out"
            )
        return self

    def with_options(self, *, workers: int | None, scheduler: str | None) -> ExecutorSection:
        """These settings with command-line choices applied (a scheduler implies Dask)."""
        if scheduler is not None and workers is not None:
            raise ConfigError("--workers and --scheduler exclude each other: a cluster has its own")
        if scheduler is not None:
            if not scheduler.strip():
                raise ConfigError("--scheduler needs an address, e.g. tcp://host:8786")
            return ExecutorSection(kind="dask", address=scheduler.strip())
        if workers is not None:
            if self.address is not None:
                raise ConfigError(
                    f"--workers conflicts with the sweep's executor address {self.address}; "
                    "pass --scheduler to choose a cluster or edit executor.address"
                )
            if workers < 1:
                raise ConfigError(f"--workers must be at least 1, got {workers}")
            return self.model_copy(update={"workers": workers})
        return self


def _check_keys(keys, where: str) -> None:
    for key in keys:
        if not isinstance(key, str) or not _KEY.match(key):
            raise ValueError(
                f"{where}: {key!r} is not a dotted config key (e.g. denoise.smoother.window_s "
                "or logs.0.path)"
            )


class SweepConfig(_Frozen):
    """A sweep: ``base`` experiment config, ``runs`` or ``grid`` of overrides, ``executor``."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")]
    base: Path
    runs: _Runs | None = None
    grid: _Grid | None = None
    executor: ExecutorSection = ExecutorSection()
    base_dir: Path = Path(".")

    @field_validator("runs")
    @classmethod
    def _run_keys(cls, runs):
        for i, overrides in enumerate(runs or ()):
            _check_keys(overrides, f"run {i + 1}")
        return runs

    @field_validator("grid")
    @classmethod
    def _grid_keys(cls, grid):
        _check_keys(grid or {}, "grid")
        return grid

    @model_validator(mode="after")
    def _one_source(self) -> SweepConfig:
        if (self.runs is None) == (self.grid is None):
            raise ValueError("give exactly one of 'runs' (a list of overrides) or 'grid'")
        return self

    @property
    def base_path(self) -> Path:
        return self.base if self.base.is_absolute() else self.base_dir / self.base

    def override_sets(self) -> tuple[dict[str, Any], ...]:
        """The overrides of every run, in order (a grid: the first key varies slowest)."""
        if self.runs is not None:
            return tuple(dict(overrides) for overrides in self.runs)
        grid = self.grid
        assert grid is not None  # exactly one of runs and grid
        keys = list(grid)
        return tuple(
            dict(zip(keys, values, strict=True))
            for values in itertools.product(*(grid[k] for k in keys))
        )


def load_sweep(path: str | Path) -> SweepConfig:
    """Read and validate a sweep config; its base experiment config must be valid too."""
    from hmid.experiment import load_experiment

    path = Path(path)
    sweep = load_yaml_model(path, SweepConfig, what="sweep config")
    sweep = sweep.model_copy(update={"base_dir": path.parent})
    if not sweep.base_path.is_file():
        raise ConfigError(
            f"{path}: key 'base': file {sweep.base_path} does not exist "
            f"(paths are relative to the sweep config's folder {path.parent})"
        )
    load_experiment(sweep.base_path)  # the base must run as it is: errors name its file
    return sweep


# ---- overrides on plain config data ------------------------------------------------------------


def apply_overrides(data: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """A copy of ``data`` with each dotted key set to its value; a bad path is a ConfigError.

    Missing mapping levels are created (the experiment's validation then rejects unknown keys);
    a number indexes a list and must lie inside it.
    """
    out = _copy(data)
    for key, value in overrides.items():
        parts = key.split(".")
        node: Any = out
        for depth, part in enumerate(parts):
            last = depth == len(parts) - 1
            here = ".".join(parts[:depth]) or "the config"
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise ConfigError(
                        f"key {key!r}: {here} is a list of {len(node)} entries; "
                        f"{part!r} is not a position in it (0 to {len(node) - 1})"
                    )
                index: int | str = int(part)
            elif isinstance(node, dict):
                index = part
            else:
                raise ConfigError(f"key {key!r}: {here} is a value ({node!r}), not a section")
            if last:
                node[index] = _copy(value)
            else:
                if isinstance(node, dict) and index not in node:
                    node[index] = {}
                node = node[index]
    return out


def _copy(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_copy(v) for v in value]
    return value
