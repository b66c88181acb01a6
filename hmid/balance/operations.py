"""Signal operations that terms share: viscoelastic (Maxwell) arms and lags of a channel."""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np

from hmid.balance.signals import Signals
from hmid.balance.terms import Hyper

if TYPE_CHECKING:
    import jax

_ARMS: OrderedDict[tuple, dict] = OrderedDict()  # per (signals, channel): tau -> row
_ARMS_KEPT = 8
_BATCH = 4  # taus scanned at once: one compiled shape, and all that an interpolation needs


def _arms_key(signals: Signals, channel: str) -> tuple:
    def digest() -> str:  # hashing the rows costs more than a cached lookup: once per signals
        found = hashlib.sha1(signals["t"].tobytes())
        found.update(signals[channel].tobytes())
        found.update(signals["segment"].tobytes())
        return found.hexdigest()

    return (signals.derived(("digest", channel), digest), channel)


def memory_arms(signals: Signals, channel: str, grid: tuple[float, ...]) -> np.ndarray:
    """g_tau(channel) for every tau of ``grid``, shape (len(grid), n). Each tau's row is
    scanned once per (signals, channel) and kept for the last few of them: profiling asks for
    the same arms many times, a sensor effect on another channel does not change them, and a
    delayed channel needs only the few taus near the model's."""
    parts = signals.cache.get(("sum of", channel))
    if parts is not None:  # the arms are linear in the channel: the parts' arms, combined
        signals[channel]  # noted as read, as it is below
        return sum(c * memory_arms(s, name, grid) for c, s, name in parts)
    key = _arms_key(signals, channel)
    table = _ARMS.get(key)
    if table is None:
        table = _ARMS[key] = {}
        while len(_ARMS) > _ARMS_KEPT:
            _ARMS.popitem(last=False)
    _ARMS.move_to_end(key)
    missing = list(dict.fromkeys(float(tau) for tau in grid if float(tau) not in table))
    if missing:
        from hmid.signal.maxwell import responses

        # one scan over all rows, restarting at each segment's first (one compiled shape,
        # however many segments)
        found = responses(*_arrays(signals, channel, table), missing, batch=_BATCH)
        for tau, row in zip(missing, np.ascontiguousarray(found.T), strict=True):
            table[tau] = row
    return np.stack([table[float(tau)] for tau in grid])


def declare_sum(signals: Signals, channel: str, parts) -> None:
    """Declare ``signals[channel]`` to be sum(c * s[name] for c, s, name in ``parts``) on every
    row, each ``s`` on the same rows and segments: its memory arms are then the parts' arms
    combined (exact: an arm is linear in its channel), and a part's arms are found once for
    every combination (a lag undone, x + T dx/dt, for every T)."""
    signals.cache[("sum of", channel)] = tuple(parts)


def _arrays(signals: Signals, channel: str, table: dict) -> tuple[jax.Array, jax.Array, jax.Array]:
    """t, the channel and the segments' first rows as float64 JAX arrays, converted once and
    kept in ``table``."""
    arrays = table.get("arrays")
    if arrays is None:
        import jax
        import jax.numpy as jnp

        start = np.zeros(len(signals), dtype=bool)
        start[[rows[0] for rows in signals.segments() if len(rows)]] = True
        with jax.enable_x64(True):
            arrays = tuple(jnp.asarray(a) for a in (signals["t"], signals[channel], start))
        table["arrays"] = arrays
    return arrays


def memory_response(signals: Signals, channel: str, tau: float, hyper: Hyper | None) -> np.ndarray:
    """g_tau(channel): a grid row, or between grid points cubic (Lagrange) interpolation in
    ln tau over the four nearest rows (g is smooth in tau: on a grid of ratio 1.17 this is within
    ~3e-5 of the exact scan, relative to the arm's range); off any grid, an exact scan."""
    if hyper is None or len(hyper.grid) < 4:
        return memory_arms(signals, channel, (float(tau),))[0]
    log_grid = np.log(np.asarray(hyper.grid))
    lt = np.log(tau)
    if not log_grid[0] - 1e-12 <= lt <= log_grid[-1] + 1e-12:
        raise ValueError(f"tau={tau} s lies outside the grid [{hyper.grid[0]}, {hyper.grid[-1]}]")
    index = int(np.argmin(np.abs(log_grid - lt)))
    if abs(log_grid[index] - lt) < 1e-12:
        return memory_arms(signals, channel, (hyper.grid[index],))[0]
    first = int(np.clip(np.searchsorted(log_grid, lt) - 2, 0, len(log_grid) - 4))
    nodes = range(first, first + 4)
    weights = [
        np.prod([(lt - log_grid[k]) / (log_grid[j] - log_grid[k]) for k in nodes if k != j])
        for j in nodes
    ]
    arms = memory_arms(signals, channel, tuple(hyper.grid[first : first + 4]))
    return np.tensordot(weights, arms, axes=1)


def lagged(signals: Signals, values: np.ndarray, time: float, kind: str) -> np.ndarray:
    """``values`` delayed by ``time`` (held at the first value before a segment starts; a
    negative time is a lead, held at the last value) or through a first-order lag of time
    constant ``time`` from steady state, per segment."""
    if time == 0:
        return np.asarray(values, dtype=float)
    t, out = signals["t"], np.empty(len(signals))
    for rows in signals.segments():
        if kind == "delay":
            out[rows] = np.interp(t[rows] - time, t[rows], values[rows])
        else:
            from scipy.signal import lfilter

            alpha = 1.0 - np.exp(-np.median(np.diff(t[rows])) / time)
            y = values[rows]
            out[rows] = lfilter([alpha], [1.0, alpha - 1.0], y, zi=[(1.0 - alpha) * y[0]])[0]
    return out
