"""From denoised log pieces to :class:`Signals`: channels, the explained quantity, the known terms
subtracted from it, and the rows where the balance can be fitted.

Both sides of the balance see the same zero-phase smoother: the model channels are its outputs
(velocity and acceleration are derivatives of the smoothed position), and the explained quantity
(a force sensor, or known parts such as a mass times the acceleration) is made of them too.
A row is *usable* unless

* the motion stops there (|v| below ``v_deadband``): friction is static and indeterminate, and
  the direction of motion unknown; the smoother smears a stop, so a row whose kernel puts more
  than :data:`STOPPED_SHARE` of its weight on stopped samples is left out as well;
* it lies within the reach of the differentiator or the smoother of a piece's ends.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from hmid.balance.kinds import CoulombTerm
from hmid.balance.rig import RigSection
from hmid.balance.signals import Signals, raw
from hmid.errors import ConfigError
from hmid.io.log import Log
from hmid.signal import Differentiator, Smoother
from hmid.signal.blocks import BLOCK, local_smoother, smoothed_span
from hmid.signal.reach import impulse_reach

#: Channel names of the denoised log for the derived signals (raw estimate, smoothed).
_DERIVED = {"v": ("v", "v_s"), "a": ("a_est", "a_s")}


def _frame(rig: RigSection, name: str, piece: Log, t0: float) -> dict:
    columns = {"log": name, "t": piece.t - t0}
    for channel in rig.log_channels:
        if channel in rig.model_channels:  # no term reads the explained quantity's channels
            columns[raw(channel)] = piece[channel]
        columns[channel] = piece[f"{channel}_s"]
    if rig.position is not None:
        for channel, (estimate, smoothed) in _DERIVED.items():
            columns[raw(channel)], columns[channel] = piece[estimate], piece[smoothed]
    return columns


def _joined(parts: list[dict]) -> pd.DataFrame:
    """One table of the pieces' columns, each copied at most once (a long log is never held as
    pieces and as this table and a third time)."""
    lengths = [len(part["t"]) for part in parts]
    logs = list(dict.fromkeys(part["log"] for part in parts))
    columns = {
        "log": pd.Categorical.from_codes(
            np.repeat([logs.index(part["log"]) for part in parts], lengths).astype(np.int32),
            logs,
        ),
        # the narrowest integer that numbers the pieces: a long log's column is a byte a row
        "segment": np.repeat(np.arange(len(parts), dtype=np.min_scalar_type(-len(parts))), lengths),
    }
    for column in parts[0]:
        if column not in columns:
            arrays = [np.asarray(part[column]) for part in parts]
            # one piece: its read-only arrays as they are (copy-on-write keeps them unchanged)
            columns[column] = arrays[0] if len(arrays) == 1 else np.concatenate(arrays)
    n = len(columns["t"])
    columns.update(target=np.zeros(n), train=np.zeros(n, bool), validation=np.zeros(n, bool))
    return pd.DataFrame(columns, copy=False)


#: A row is left out when stopped samples weigh this much in its smoothing kernel: its smoothed
#: force then mixes in at most this share of static friction (indeterminate, up to 2 Fc).
STOPPED_SHARE = 0.02


def _usable(t, v_raw, smoother, ends: int, v_deadband: float, exclude_stuck: bool):
    usable = np.ones(len(t), dtype=bool)
    if exclude_stuck and v_raw is not None:

        def stopped(rows: slice) -> np.ndarray:
            return (np.abs(v_raw[rows]) < v_deadband).astype(float)

        local = local_smoother(smoother, t)
        for lo in range(0, len(t), BLOCK):  # a long log's share is never held whole
            hi = min(lo + BLOCK, len(t))
            share = smoothed_span(local, len(t), stopped, lo, hi)
            usable[lo:hi] &= (stopped(slice(lo, hi)) == 0) & (share <= STOPPED_SHARE)
    usable[: min(ends, len(usable))] = False
    usable[max(len(usable) - ends, 0) :] = False
    return usable


def without_stopped(signals: Signals, v_deadband: float) -> Signals:
    """``signals`` with the low-speed rule applied to rows that kept stopped motion (as
    ``fit.exclude_stuck`` would have in :func:`prepare`): for a refit once friction is found
    where the rig declared none."""
    keep = np.ones(len(signals), dtype=bool)
    t, v_raw = signals["t"], signals[raw("v")]
    for start, stop in signals.bounds():
        rows = slice(start, stop)
        keep[rows] = _usable(t[rows], v_raw[rows], signals.smoother, 0, v_deadband, True)
    return signals.with_columns(usable=signals.usable & keep, train=signals.train & keep,
                                validation=signals.validation & keep)  # fmt: skip


def _parts(
    rig: RigSection,
    pieces: Mapping[str, list[Log]],
    smoother: Smoother,
    differentiator: Differentiator,
    v_deadband: float,
    exclude_stuck: bool,
) -> list[dict]:
    """The columns of every piece, times from its log's start, with the rows it can fit."""
    parts: list[dict] = []
    for name, logs in pieces.items():
        t0 = logs[0].t[0]
        for piece in logs:
            columns = _frame(rig, name, piece, t0)
            smooth_reach = impulse_reach(piece.t, smoother)
            derivative_reach = (
                impulse_reach(piece.t, lambda t, y: differentiator.derivative(t, y, 1))
                if rig.position is not None
                else 0
            )
            columns["usable"] = _usable(
                piece.t, columns.get(raw("v")), smoother, max(derivative_reach, smooth_reach),
                v_deadband, exclude_stuck,
            )  # fmt: skip
            parts.append(columns)
    return parts


def _explained(rig: RigSection, signals: Signals, units: Mapping[str, str]) -> np.ndarray:
    """The explained quantity, on the smoothed signals as a channel term is: a single channel
    (a force sensor, an acceleration) is then exactly its smoothed self."""
    explained = np.zeros(len(signals))
    for value, part in zip(rig.part_values(units), rig.explained.parts, strict=True):
        powers = part.powers()
        if len(rig.explained.parts) == 1 and value == 1 and list(powers.values()) == [1]:
            return signals[next(iter(powers))]  # a force sensor: that column, not a copy
        values = np.full(len(signals), value)
        for channel, power in powers.items():
            values = values * signals[channel] ** power
        explained += values
    return explained


def _known(
    rig: RigSection,
    signals: Signals,
    units: Mapping[str, str],
    free_fall_law: Callable[[np.ndarray], np.ndarray] | None,
) -> np.ndarray:
    """The sum of the rig's known terms, the free-fall friction smoothed as the signals are."""
    known = None
    for term in rig.known:
        if isinstance(term, CoulombTerm) and term.source == "free_fall":
            if free_fall_law is None:
                raise ConfigError(f"rig.balance: term {term.name!r} needs the free-fall friction")
            v = signals[raw(term.channel)]

            def law_on(rows: slice, v: np.ndarray = v) -> np.ndarray:
                return free_fall_law(v[rows])

            part = signals.smooth_of(law_on)
            part *= term.sign
        else:
            part = rig.term_value(term, units) * term.columns(signals, None).values[:, 0]
        if known is None:  # the first term is the sum so far (a long log's is not held twice)
            known = part
            known += 0.0  # as a sum from zero: -0.0 becomes 0.0
        else:
            known += part
        del part
    return np.zeros(len(signals)) if known is None else known


def prepare(
    rig: RigSection,
    pieces: Mapping[str, list[Log]],
    units: Mapping[str, str],
    *,
    smoother: Smoother,
    differentiator: Differentiator,
    free_fall_law: Callable[[np.ndarray], np.ndarray] | None = None,
    v_deadband: float = 0.002,
    exclude_stuck: bool = True,
) -> Signals:
    """Signals of every dynamic log's pieces (see the module docstring); ``free_fall_law(v)`` is
    the friction the free-fall tests identified (N, signed with v), for the terms that take it."""
    parts = _parts(rig, pieces, smoother, differentiator, v_deadband, exclude_stuck)
    if not parts:
        raise ConfigError("logs: no log has role 'dynamic'; there is nothing to identify")
    frame = _joined(parts)
    signals = Signals(frame, units, rig.model_channels, rig.position, smoother)
    explained = _explained(rig, signals, units)
    known = _known(rig, signals, units, free_fall_law)
    target = np.subtract(explained, known, out=known)  # a long log's known part is let go
    return signals.with_columns(explained=explained, target=target)
