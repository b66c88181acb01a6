"""Writing a simulated data set of any rig to disk as a logger would: data, column maps, truth.

A written set holds, per log, ``<name>.csv`` (or ``.parquet``) in the logger's units and
``<name>.truth.json``; the rig's column maps (:meth:`~hmid.simulate.dataset.RigDataset.column_map`);
``index.yaml`` listing each log with its kind and column map; and ``dataset.yaml``, the resolved
config that regenerates the set exactly. Entries that are not logs (the Hydro Muscle rig's Ch. 2
relaxation runs) write their own files.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from hmid.files import atomic_path, fresh_dir, write_json, write_text
from hmid.simulate.dataset import RigDataset


def write_table(table: pd.DataFrame, path: Path) -> Path:
    """Write ``table`` atomically as CSV (10 significant digits) or Parquet, by the suffix."""
    with atomic_path(path) as tmp:
        if path.suffix == ".csv":
            table.to_csv(tmp, index=False, float_format="%.10g")
        else:
            table.to_parquet(tmp, index=False)
    return path


def write_truth(folder: Path, name: str, truth: dict[str, Any]) -> Path:
    """The log's ground truth, ``<name>.truth.json``, beside (never inside) its data."""
    return write_json(folder / f"{name}.truth.json", truth)


def write_catalogue(folder: Path, maps: dict[str, dict], index: list[dict], resolved: dict) -> None:
    """The column maps, ``index.yaml`` and ``dataset.yaml`` (the resolved config) of a set."""
    for map_name, mapping in maps.items():
        write_text(folder / map_name, yaml.safe_dump(mapping, sort_keys=False))
    write_text(folder / "index.yaml", yaml.safe_dump({"logs": index}, sort_keys=False))
    write_text(folder / "dataset.yaml", yaml.safe_dump(resolved, sort_keys=False))


def write_dataset(
    config: RigDataset,
    folder: str | Path,
    *,
    replace: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Simulate every log of ``config``, whatever its rig, into ``folder`` (new or empty,
    unless ``replace``); the paths written, one per entry."""
    if not isinstance(config, RigDataset):
        raise TypeError(f"not a data-set config: {type(config).__name__}")
    folder = fresh_dir(folder, replace=replace)
    paths, maps, index = [], {}, []
    for spec in config.logs:
        if progress:
            progress(spec.name)
        extra = config.write_extra(spec, folder)
        if extra is not None:
            paths.append(extra)
            continue
        sim = config.simulate(spec)
        path = write_table(config.table(sim), folder / f"{spec.name}.{config.output.format}")
        write_truth(folder, spec.name, sim.truth)
        map_name, mapping = config.column_map(spec)
        maps[map_name] = mapping
        index.append({"name": spec.name, "kind": spec.kind, "file": path.name, "columns": map_name})
        paths.append(path)
    write_catalogue(folder, maps, index, config.model_dump(mode="json"))
    return paths
