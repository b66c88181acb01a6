"""Writing simulated stage data sets to disk as the drive's logger would.

The same files as :func:`hmid.simulate.write.write_dataset`: per log ``<name>.csv`` (or
``.parquet``) with columns t, x, u in the logger's units and ``<name>.truth.json``; the column map
``columns-dynamic.yaml``; ``index.yaml``; ``dataset.yaml``, the resolved config that regenerates
the set exactly.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.files import fresh_dir, write_json
from hmid.simulate.stage_dataset import StageDatasetConfig, StageUnits, simulate_stage_log
from hmid.simulate.write import _from_si, column_name, write_catalogue, write_table

CHANNELS = ("t", "x", "u")


def stage_column_map(units: StageUnits) -> dict:
    """The column map that reads written stage logs back (no ranges: the encoder has no rails)."""
    channels = {c: {"column": column_name(c, units[c]), "unit": units[c]} for c in CHANNELS}
    return {"delimiter": ",", "header": True, "channels": channels}


def _table(frame: pd.DataFrame, units: StageUnits, encoder_step: float) -> pd.DataFrame:
    out = {}
    for c in CHANNELS:
        values = frame[c].to_numpy()
        if c == "x":
            # whole encoder steps, converted from exact integers so the text stays short
            counts = np.round(values / encoder_step)
            values = counts * _from_si(np.array([encoder_step]), "x", units.x)[0]
        else:
            values = _from_si(values, c, units[c])
        out[column_name(c, units[c])] = values
    return pd.DataFrame(out)


def write_stage_dataset(
    config: StageDatasetConfig,
    folder: str | Path,
    *,
    replace: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Simulate every log of ``config`` into ``folder`` (new or empty, unless ``replace``)."""
    folder = fresh_dir(folder, replace=replace)
    units = config.output.units
    map_name = "columns-dynamic.yaml"
    paths, index = [], []
    for spec in config.logs:
        if progress:
            progress(spec.name)
        sim = simulate_stage_log(config, spec)
        table = _table(sim.log.to_frame(), units, config.sensors.encoder_step)
        path = write_table(table, folder / f"{spec.name}.{config.output.format}")
        write_json(folder / f"{spec.name}.truth.json", sim.truth)
        index.append({"name": spec.name, "kind": "dynamic", "file": path.name, "columns": map_name})
        paths.append(path)
    maps = {map_name: stage_column_map(units)}
    write_catalogue(folder, maps, index, config.model_dump(mode="json"))
    return paths
