"""The rows the loop works on: whole segments (for memory and lags), with train/held-out masks."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.errors import ConfigError

COLUMNS = ("log", "segment", "t", "x", "v", "P", "y", "train", "validation")


@dataclass(frozen=True)
class LoopData:
    """Every sample of every contiguous segment, in time order.

    ``frame`` has columns log, segment (an integer id), t (s since the log's first sample), x [m],
    v [m/s], P [Pa], y (the target force, N), train and validation (bool). Rows in neither set
    (stuck block, derivative reach, a lag's reach at a segment end) still carry the signals that
    memory and lag terms need, so every design is evaluated on whole segments and then masked.
    """

    frame: pd.DataFrame

    def __post_init__(self) -> None:
        missing = [c for c in COLUMNS if c not in self.frame.columns]
        if missing:
            raise ValueError(f"LoopData needs columns {missing}")
        if (self.frame["train"] & self.frame["validation"]).any():
            raise ValueError("a row cannot be both training and held-out")

    def __len__(self) -> int:
        return len(self.frame)

    def __getitem__(self, column: str) -> np.ndarray:
        return self.frame[column].to_numpy()

    @property
    def train(self) -> np.ndarray:
        return self.frame["train"].to_numpy()

    @property
    def validation(self) -> np.ndarray:
        return self.frame["validation"].to_numpy()

    def segments(self) -> Iterator[np.ndarray]:
        """Row indices of each segment, in order."""
        ids = self.frame["segment"].to_numpy()
        edges = np.flatnonzero(np.diff(ids)) + 1
        yield from np.split(np.arange(len(ids)), edges)

    def with_columns(self, **columns: np.ndarray) -> LoopData:
        return LoopData(self.frame.assign(**columns))

    def trim_segment_ends(self, seconds: float) -> LoopData:
        """No fitting or scoring within ``seconds`` of a segment's end (a lead/lag reaches past
        it); the rows stay for the signals."""
        if seconds <= 0:
            return self
        t = self["t"]
        keep = np.ones(len(self), dtype=bool)
        for rows in self.segments():
            keep[rows] = t[rows] <= t[rows[-1]] - seconds
        return self.with_columns(train=self.train & keep, validation=self.validation & keep)


def from_sequences(sequences: Mapping[str, pd.DataFrame], target: str = "F_m") -> LoopData:
    """From the pipeline split's whole-log sequences (t, x, v, P, F_m, train, validation)."""
    frames = []
    for i, (name, seq) in enumerate(sequences.items()):
        t = seq["t"].to_numpy()
        frames.append(
            pd.DataFrame(
                {
                    "log": name,
                    "segment": i,
                    "t": t - t[0],
                    "x": seq["x"].to_numpy(),
                    "v": seq["v"].to_numpy(),
                    "P": seq["P"].to_numpy(),
                    "y": seq[target].to_numpy(),
                    "train": seq["train"].to_numpy(bool),
                    "validation": seq["validation"].to_numpy(bool),
                }
            )
        )
    if not frames:
        raise ConfigError("loop: there are no dynamic logs to analyse")
    return LoopData(pd.concat(frames, ignore_index=True))


def from_segments(
    segments: Mapping[str, list],
    *,
    target: str,
    validation: set[str],
    v_deadband: float,
    reach: int,
) -> LoopData:
    """From denoised log pieces (channels x, v, P and ``target``), whole logs held out.

    ``segments`` maps a log name to its contiguous pieces (:func:`hmid.io.segments.split_at_gaps`
    then denoised); ``t`` counts from each log's first sample. Rows within ``reach`` samples of a
    piece's ends (the derivative is less accurate there) or with ``|v| < v_deadband`` (direction
    unknown) are neither trained on nor scored; they stay for the signals.
    """
    frames, segment = [], 0
    for name, pieces in segments.items():
        t0 = pieces[0].t[0]
        for piece in pieces:
            n = len(piece)
            usable = np.abs(piece["v"]) >= v_deadband
            usable[: min(reach, n)] = False
            usable[max(n - reach, 0) :] = False
            held = name in validation
            frames.append(
                pd.DataFrame(
                    {
                        "log": name,
                        "segment": segment,
                        "t": piece.t - t0,
                        "x": piece["x"],
                        "v": piece["v"],
                        "P": piece["P"],
                        "y": piece[target],
                        "train": usable & (not held),
                        "validation": usable & held,
                    }
                )
            )
            segment += 1
    if not frames:
        raise ConfigError("loop: there are no logs to analyse")
    return LoopData(pd.concat(frames, ignore_index=True))
