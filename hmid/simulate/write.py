"""Writing simulated data sets to disk as a logger would: data files, column maps, ground truth.

A written set holds, per log, ``<name>.csv`` (or ``.parquet``) in the logger's units and
``<name>.truth.json``; a column map per sensor set (``columns-dynamic.yaml``,
``columns-free_fall.yaml``, or ``<name>.columns.yaml`` for a log with its own sensors);
``index.yaml`` listing each log with its kind and column map; ``dataset.yaml``, the resolved
config that regenerates the set exactly; and for a Ch. 2 relaxation entry its curves (CSV), figure
(PNG) and numbers (``<name>.truth.json``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from hmid.files import atomic_path, fresh_dir, write_json, write_text
from hmid.io.units import unit_registry
from hmid.simulate.dataset import DatasetConfig, DynamicLog, FreeFallLog, Simulated, simulate_log
from hmid.simulate.params import Sensors
from hmid.simulate.relaxation import RelaxationRun, write_relaxation

_SI = {"t": "s", "P": "Pa", "x": "m", "F": "N", "u": "N"}


def _from_si(values: np.ndarray, channel: str, unit: str) -> np.ndarray:
    return (
        unit_registry().Quantity(np.asarray(values, dtype=float), _SI[channel]).to(unit).magnitude
    )


def column_name(channel: str, unit: str) -> str:
    return f"{channel}_{unit.replace('/', '_per_').replace('^', '')}"


def column_map(sensors: Sensors, units: dict[str, str], channels: tuple[str, ...]) -> dict:
    """The column map (``hmid.io.columns.ColumnMap`` schema) that reads written logs back.

    Each sensed channel carries its ADC's reachable span (lo to hi - 1 LSB) as ``range`` so the
    loader flags saturated samples.
    """
    out = {"t": {"column": column_name("t", units["t"]), "unit": units["t"]}}
    for name in channels:
        spec = getattr(sensors, name)
        lo, hi = _from_si(np.array([spec.lo, spec.hi - spec.lsb]), name, units[name])
        out[name] = {
            "column": column_name(name, units[name]),
            "unit": units[name],
            # rounded like the written data, so a sample at a rail compares equal to the limit
            "range": [float(f"{lo:.10g}"), float(f"{hi:.10g}")],
        }
    return {"delimiter": ",", "header": True, "channels": out}


def write_log(sim: Simulated, folder: Path, config: DatasetConfig) -> Path:
    """Write one simulated log (data file in the logger's units) and its truth JSON."""
    units = config.output.units
    frame = sim.log.to_frame()
    out = {column_name(c, units[c]): _from_si(frame[c].to_numpy(), c, units[c]) for c in frame}
    table = pd.DataFrame(out)
    name = sim.truth["name"]
    path = write_table(table, folder / f"{name}.{config.output.format}")
    write_json(folder / f"{name}.truth.json", sim.truth)
    return path


def write_table(table: pd.DataFrame, path: Path) -> Path:
    """Write ``table`` atomically as CSV (10 significant digits) or Parquet, by the suffix."""
    with atomic_path(path) as tmp:
        if path.suffix == ".csv":
            table.to_csv(tmp, index=False, float_format="%.10g")
        else:
            table.to_parquet(tmp, index=False)
    return path


def write_catalogue(folder: Path, maps: dict[str, dict], index: list[dict], resolved: dict) -> None:
    """The column maps, ``index.yaml`` and ``dataset.yaml`` (the resolved config) of a set."""
    for map_name, mapping in maps.items():
        write_text(folder / map_name, yaml.safe_dump(mapping, sort_keys=False))
    write_text(folder / "index.yaml", yaml.safe_dump({"logs": index}, sort_keys=False))
    write_text(folder / "dataset.yaml", yaml.safe_dump(resolved, sort_keys=False))


def _map_file(config: DatasetConfig, spec: DynamicLog | FreeFallLog) -> tuple[str, dict]:
    free_fall = isinstance(spec, FreeFallLog)
    channels = ("x", "F") if free_fall else ("P", "x", "F")
    if spec.sensors is not None:
        return f"{spec.name}.columns.yaml", column_map(spec.sensors, config.output.units, channels)
    sensors = config.free_fall_sensors if free_fall else config.sensors
    return f"columns-{spec.kind}.yaml", column_map(sensors, config.output.units, channels)


def write_dataset(
    config: DatasetConfig,
    folder: str | Path,
    *,
    replace: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Simulate every log of ``config`` into ``folder`` (new or empty, unless ``replace``)."""
    folder = fresh_dir(folder, replace=replace)
    paths, maps, index = [], {}, []
    for spec in config.logs:
        if progress:
            progress(spec.name)
        if isinstance(spec, RelaxationRun):
            write_relaxation(spec, folder)
            paths.append(folder / f"{spec.name}.csv")
            continue
        path = write_log(simulate_log(config, spec), folder, config)
        map_name, mapping = _map_file(config, spec)
        maps[map_name] = mapping
        index.append({"name": spec.name, "kind": spec.kind, "file": path.name, "columns": map_name})
        paths.append(path)
    write_catalogue(folder, maps, index, config.model_dump(mode="json"))
    return paths
