"""The :class:`Log` type: one sampled rig record in SI units.

A log is a time column ``t`` plus named channels (``P``, ``x``, ``F``, optional ``a``, ``v``, and
any others), all float64 in SI units, with the metadata needed to interpret it: where it came from,
and non-fatal findings from validation (``flags``). Logs are immutable:
methods that change data return a new log.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
import pandas as pd

from hmid.errors import LogError

#: SI unit of each canonical channel; other channels carry the SI base unit of their dimension.
CANONICAL_UNITS: Mapping[str, str] = MappingProxyType(
    {
        "t": "s",  # time
        "P": "Pa",  # pressure, gauge
        "x": "m",  # elongation / block position
        "v": "m/s",  # velocity
        "a": "m/s^2",  # acceleration
        "F": "N",  # measured (load-cell) force
    }
)


@dataclass(frozen=True, eq=False)
class Log:
    """A validated rig log: ``data`` holds ``t`` and the channels, float64, SI units."""

    data: pd.DataFrame
    source: str = "<memory>"
    units: Mapping[str, str] = field(default_factory=dict)
    flags: tuple[str, ...] = ()
    meta: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if "t" not in self.data.columns:
            raise LogError(f"{self.source}: a log needs a time column 't'")
        frame = self.data.reset_index(drop=True).astype("float64")
        units = {name: self.units.get(name, CANONICAL_UNITS.get(name, "")) for name in frame}
        missing = [name for name, unit in units.items() if not unit]
        if missing:
            raise LogError(f"{self.source}: no unit given for channel(s) {missing}")
        object.__setattr__(self, "data", frame)
        object.__setattr__(self, "units", MappingProxyType(units))
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))
        object.__setattr__(self, "flags", tuple(self.flags))

    # read-only mappings do not pickle; stage caches pickle logs
    def __getstate__(self) -> dict:
        return self.__dict__ | {"units": dict(self.units), "meta": dict(self.meta)}

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            if name in ("units", "meta"):
                value = MappingProxyType(value)
            object.__setattr__(self, name, value)

    # -- access -----------------------------------------------------------------------------
    def __getitem__(self, channel: str) -> np.ndarray:
        """The channel's samples as a read-only float64 array."""
        if channel not in self.data.columns:
            raise KeyError(f"{self.source}: no channel {channel!r}; it has {list(self.data)}")
        # a read-only view, not a copy: a long log's channels are read many times over
        values = self.data[channel].to_numpy(dtype="float64", copy=False)
        values.flags.writeable = False
        return values

    def __contains__(self, channel: object) -> bool:
        return channel in self.data.columns

    def __len__(self) -> int:
        return len(self.data)

    @property
    def t(self) -> np.ndarray:
        return self["t"]

    @property
    def channels(self) -> tuple[str, ...]:
        """Channel names other than time."""
        return tuple(c for c in self.data.columns if c != "t")

    @property
    def duration(self) -> float:
        t = self.data["t"].to_numpy()
        return float(t[-1] - t[0]) if len(t) else 0.0

    @property
    def sample_rate(self) -> float:
        """Median sampling rate in Hz (robust to occasional gaps)."""
        dt = np.diff(self.data["t"].to_numpy())
        # dt is this call's own: the median may reorder it rather than copy it
        return float(1.0 / np.median(dt, overwrite_input=True)) if len(dt) else float("nan")

    # -- derived logs -----------------------------------------------------------------------
    def with_channels(self, units: Mapping[str, str] | None = None, **channels: np.ndarray) -> Log:
        """A new log with channels added or replaced (same length as this one). The new
        channels' arrays are taken as they are, not copied (a long log's are held once): the
        caller lets go of them."""
        added = {}
        for name, values in channels.items():
            values = np.asarray(values, dtype="float64")
            if values.shape != (len(self.data),):
                raise LogError(
                    f"{self.source}: channel {name!r} has shape {values.shape}, "
                    f"expected ({len(self.data)},)"
                )
            added[name] = pd.Series(values, index=self.data.index, copy=False)
        frame = self.data.assign(**added)  # copy-on-write: this log's columns stay as they are
        merged = dict(self.units) | dict(units or {})
        return Log(frame, self.source, merged, self.flags, self.meta)

    def between(self, t0: float, t1: float) -> Log:
        """The samples with ``t0 <= t <= t1`` as a new log."""
        t = self.data["t"].to_numpy()
        frame = self.data.loc[(t >= t0) & (t <= t1)]
        return Log(frame, self.source, self.units, self.flags, self.meta)

    def to_frame(self) -> pd.DataFrame:
        """A copy of the data as a DataFrame (SI units)."""
        return self.data.copy()

    def __repr__(self) -> str:
        return (
            f"Log({self.source!r}, n={len(self)}, {self.duration:.3f} s, "
            f"{self.sample_rate:.1f} Hz, channels={list(self.channels)})"
        )
