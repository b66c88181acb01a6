"""What a simulated rig's data set provides: its config, its logs, their truth records.

A data-set config (one class per rig, in :mod:`hmid.simulate.rigs`) lists logs; each log is
simulated from its own seed (the data set's seed mixed with the log's name, so adding or
reordering logs does not change the others), measured by the rig's sensors, and returned as a
:class:`Simulated`: a :class:`~hmid.io.log.Log` in SI units, the true trajectory and a
ground-truth record. The truth never goes into the log that the pipeline reads;
:func:`hmid.simulate.write.write_dataset` puts it in ``<name>.truth.json`` beside the data.

A rig's config subclasses :class:`RigDataset` and fills in :meth:`~RigDataset.simulate` (one
log), :meth:`~RigDataset.column_map` (how its written logs read back) and, where it writes a
channel other than by unit conversion, :meth:`~RigDataset.logged`.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NamedTuple, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from hmid import __version__
from hmid.io.log import Log
from hmid.io.units import unit_registry
from hmid.simulate.rig import Trajectory

if TYPE_CHECKING:
    import pandas as pd

Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", max_length=80)]

#: The SI unit each logged channel is simulated in.
SI_UNITS = {"t": "s", "P": "Pa", "x": "m", "F": "N", "u": "N"}


class Simulated(NamedTuple):
    """One simulated log with its true trajectory and the truth record."""

    log: Log
    trajectory: Trajectory
    truth: dict[str, Any]


def from_si(values: np.ndarray, channel: str, unit: str) -> np.ndarray:
    """``values`` of ``channel`` (in its SI unit) converted to ``unit``."""
    quantity = unit_registry().Quantity(np.asarray(values, dtype=float), SI_UNITS[channel])
    return quantity.to(unit).magnitude


def column_name(channel: str, unit: str) -> str:
    """The written column of ``channel`` in ``unit`` (``x_mm``, ``P_kPa``)."""
    return f"{channel}_{unit.replace('/', '_per_').replace('^', '')}"


def unique_names(logs: Iterable[Any]) -> None:
    """Raise a ValueError (for a config validator) listing repeated log names."""
    names = [log.name for log in logs]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ValueError(f"log names must be unique; repeated: {dupes}")


class LogSpecLike(Protocol):
    """What the truth record reads of a log entry (each rig's own pydantic model)."""

    @property
    def name(self) -> str: ...

    def model_dump(self, *, mode: str = ...) -> dict[str, Any]: ...


class RigDataset(BaseModel):
    """Base of every rig's data-set config: what the shared writer needs of it.

    Subclasses declare the fields ``seed``, ``output`` (``format`` and ``units``) and ``logs``
    (each with a ``name`` and a ``kind``), in the order their ``dataset.yaml`` lists them.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    if TYPE_CHECKING:  # each subclass declares them, in its own order (pydantic fields)
        seed: int
        output: Any  # the rig's output section: ``format`` and ``units``
        logs: tuple[Any, ...]

    def seed_for(self, spec: Any) -> int:
        """The log's own seed: given, or the data set's mixed with the log's name."""
        return spec.seed if spec.seed is not None else self.seed ^ zlib.crc32(spec.name.encode())

    def simulate(self, spec: Any) -> Simulated:
        """Simulate, measure and package one log."""
        raise NotImplementedError

    def column_map(self, spec: Any) -> tuple[str, dict]:
        """The column map's file name and content (``hmid.io.columns.ColumnMap`` schema)."""
        raise NotImplementedError

    def logged(self, channel: str, values: np.ndarray) -> np.ndarray:
        """A channel as the logger writes it: by default converted to the output's unit."""
        return from_si(values, channel, self.output.units[channel])

    def table(self, sim: Simulated) -> pd.DataFrame:
        """The log's data file: one column per channel, in the logger's units."""
        import pandas as pd

        frame, units = sim.log.to_frame(), self.output.units
        return pd.DataFrame(
            {column_name(c, units[c]): self.logged(c, frame[c].to_numpy()) for c in frame}
        )

    def write_extra(self, spec: Any, folder: Path) -> Path | None:
        """Write an entry that is not a log (its own files); None for a log."""
        return None

    def truth_kind(self) -> dict[str, str]:
        """The rig's ``kind`` as the truth record states it (none for the default rig)."""
        return {}


def truth_record(
    config: RigDataset,
    spec: LogSpecLike,
    seed: int,
    params: dict[str, Any],
    tail: dict[str, Any],
) -> dict[str, Any]:
    """The ground-truth record of one log: provenance, the log's spec, the rig's parameters
    (``params``, with its sensors and substeps), then what the rig adds (``tail``: the law's
    true values and the checks on the run)."""
    head = {"generator": f"hmid {__version__}", **config.truth_kind(), "name": spec.name}
    return head | {"seed": seed, "log": spec.model_dump(mode="json")} | params | tail
