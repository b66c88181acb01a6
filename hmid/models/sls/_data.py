"""The data an SLS likelihood reads: concatenated logs as one pytree of float64 arrays.

:class:`SLSData` is passed as an *argument* to the jitted likelihood (never closed over), so a new
data set of the same length reuses the compiled code. Several logs are concatenated; ``start``
marks the first sample of each, where the Maxwell arms restart from rest (q = 0) and no velocity
is taken across the boundary. ``use`` selects the samples that enter the likelihood; the caller
leaves out stuck samples, held-out rows and a memory warm-up after each log start (the arms start
at q = 0, which is only right after a long rest).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd

from hmid.errors import SignalError, where

_COLUMNS = ("t", "x", "P", "F", "use")


class SLSData(NamedTuple):
    """Concatenated logs (SI units), all arrays of shape (n,).

    ``t`` [s] time (strictly increasing within a log; it may restart between logs), ``x`` [m]
    elongation, ``P`` [Pa] gauge pressure, ``F`` [N] observed muscle force, ``use`` (bool) the
    samples in the likelihood, ``start`` (bool) the first sample of each log, ``x3`` [m³] the
    cubic spring's regressor: x³, or where ``x`` and ``F`` are smoothed, the smoothed cube of the
    unsmoothed x (the cube of a smoothed x is biased by x's variation within the kernel).
    """

    t: jax.Array
    x: jax.Array
    P: jax.Array
    F: jax.Array
    use: jax.Array
    start: jax.Array
    x3: jax.Array

    @property
    def n(self) -> int:
        return int(self.t.shape[0])


def sls_data(segments: Sequence[pd.DataFrame]) -> SLSData:
    """Concatenate logs (DataFrames with columns t, x, P, F, use, optional x3 (default x³))
    into one :class:`SLSData`.

    ``t``, ``x`` and ``P`` must be finite everywhere (the memory recursion reads every sample);
    ``F`` must be finite where ``use`` is true (it is never read elsewhere and is stored as 0
    there). Raises a one-line :class:`~hmid.errors.SignalError` naming segment, column and row.
    """
    if isinstance(segments, pd.DataFrame):
        segments = [segments]
    if len(segments) == 0:
        raise SignalError("sls_data: no segments given; pass a list of DataFrames")
    parts: dict[str, list[np.ndarray]] = {c: [] for c in (*_COLUMNS, "start", "x3")}
    for i, frame in enumerate(segments):
        for name, values in _segment(frame, f"sls_data segment {i}").items():
            parts[name].append(values)
    arrays = {name: np.concatenate(chunks) for name, chunks in parts.items()}
    if not arrays["use"].any():
        raise SignalError("sls_data: no sample has use=True; nothing would enter the likelihood")
    with jax.enable_x64(True):
        return SLSData(
            t=jnp.asarray(arrays["t"], dtype=jnp.float64),
            x=jnp.asarray(arrays["x"], dtype=jnp.float64),
            P=jnp.asarray(arrays["P"], dtype=jnp.float64),
            F=jnp.asarray(arrays["F"], dtype=jnp.float64),
            use=jnp.asarray(arrays["use"], dtype=bool),
            start=jnp.asarray(arrays["start"], dtype=bool),
            x3=jnp.asarray(arrays["x3"], dtype=jnp.float64),
        )


def _segment(frame: pd.DataFrame, source: str) -> dict[str, np.ndarray]:
    """One log's arrays, checked: its float64 columns (``F`` 0 where unused, ``x3`` x³ where
    not given), ``use``, and ``start`` (true at its first sample)."""
    use = _use(frame, source)
    names = ("t", "x", "P", "F", *(("x3",) if "x3" in frame.columns else ()))
    columns = {name: _finite(frame, source, name, use) for name in names}
    steps = np.diff(columns["t"])
    if not (steps > 0).all():
        row = int(np.argmin(steps > 0)) + 1
        raise SignalError(
            f"{where(source, 't', row)}time {columns['t'][row]} does not increase "
            f"(previous {columns['t'][row - 1]}); sort the log or split it there"
        )
    columns["F"] = np.where(use, columns["F"], 0.0)
    columns.setdefault("x3", columns["x"] ** 3)
    start = np.zeros(len(frame), dtype=bool)
    start[0] = True
    return {**columns, "use": use, "start": start}


def _use(frame: pd.DataFrame, source: str) -> np.ndarray:
    """The ``use`` mask of a segment that is a DataFrame with every column and two rows."""
    if not isinstance(frame, pd.DataFrame):
        raise SignalError(f"{source}: expected a pandas DataFrame, got {type(frame).__name__}")
    missing = [c for c in _COLUMNS if c not in frame.columns]
    if missing:
        raise SignalError(f"{source}: missing columns {missing}; need {list(_COLUMNS)} (SI units)")
    if len(frame) < 2:
        raise SignalError(f"{source}: has {len(frame)} rows; a log needs at least 2")
    use = frame["use"].to_numpy()
    if use.dtype != bool:
        raise SignalError(
            f"{where(source, 'use')}must be boolean, got dtype {use.dtype}; use a True/False mask"
        )
    return use


def _finite(frame: pd.DataFrame, source: str, name: str, use: np.ndarray) -> np.ndarray:
    """Column ``name`` as float64, finite everywhere (``F``: on the used rows)."""
    try:
        values = frame[name].to_numpy(dtype="float64")
    except (TypeError, ValueError):
        raise SignalError(f"{where(source, name)}not numeric (dtype {frame[name].dtype})") from None
    finite = np.isfinite(values) | (~use if name == "F" else False)
    if not finite.all():
        row = int(np.argmin(finite))
        extra = " on a used row" if name == "F" else ""
        raise SignalError(
            f"{where(source, name, row)}value {values[row]} is not finite{extra}; "
            "drop or interpolate it, or split the log there"
        )
    return values
