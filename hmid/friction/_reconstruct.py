"""Muscle force of a dynamic log from the load cell (eqs. 4.1-4.2) or the acceleration (eq. 5.1)."""

from __future__ import annotations

from typing import Literal

import numpy as np

from hmid.errors import ConfigError, LogError
from hmid.friction._estimate import FrictionEstimate
from hmid.io.log import Log, RigConstants

_PRODUCED_BY = {
    "v": "the denoise stage (hmid.denoise.denoise_log) estimates it from x",
    "a_est": "the denoise stage (hmid.denoise.denoise_log) estimates it from x",
    "F": "it is the load-cell channel of the log file; for a rig without a load cell use "
    "source='acceleration'",
}


def _channel(log: Log, name: str) -> np.ndarray:
    if name not in log:
        raise LogError(f"{log.source}: reconstructing F_m needs channel {name!r}; "
                       f"{_PRODUCED_BY[name]}")  # fmt: skip
    values = log[name]
    bad = ~np.isfinite(values)
    if bad.any():
        raise LogError(
            f"{log.source}: reconstruct: column {name!r} row {int(np.argmax(bad))} is not finite"
        )
    return values


def reconstruct_muscle_force(
    log: Log,
    rig: RigConstants,
    friction: FrictionEstimate,
    *,
    source: Literal["load_cell", "acceleration"] = "load_cell",
    v_deadband: float = 0.002,
) -> Log:
    """``log`` with channels ``F_m`` (N), ``friction`` (N) and ``sliding`` (1.0 / 0.0).

    * ``source="load_cell"``: ``F_m = F + friction(v)`` (eqs. 4.1 and 4.2: the load cell reads
      ``(M + m1) a + m1 g``, which is the muscle force less the friction).
    * ``source="acceleration"`` (no load cell, eq. 5.1):
      ``F_m = (M + m1) a_est + m1 g + friction(v)``.

    ``friction(v)`` is the pooled estimate's law, signed by the estimated velocity ``v``. Where
    ``|v| < v_deadband`` the block is taken as stuck: ``friction`` is 0 and ``sliding`` is 0.
    While stuck, friction is static and takes whatever value in [-F_s, F_s] balances the other
    forces, so no friction model can supply it; ``F_m`` there is the load-cell (or inertial)
    force alone and fitting should leave those samples out (``sliding == 0``). Inside the
    deadband the sign of the estimated velocity is also unreliable.
    """
    if source not in ("load_cell", "acceleration"):
        raise ConfigError(f"rig.force_source={source!r} must be 'load_cell' or 'acceleration'")
    if not (np.isfinite(v_deadband) and v_deadband >= 0):
        raise ConfigError(f"friction.v_deadband={v_deadband!r} must be a speed >= 0 m/s")
    if rig.M is None or rig.m1 is None:
        raise ConfigError(
            f"rig: reconstructing F_m needs M and m1, got M={rig.M}, m1={rig.m1}; "
            "set rig: {M: ..., m1: ...} in the experiment config"
        )
    v = _channel(log, "v")
    if source == "load_cell":
        base = _channel(log, "F")
    else:
        base = (rig.M + rig.m1) * _channel(log, "a_est") + rig.m1 * rig.g
    sliding = np.abs(v) >= v_deadband
    f = np.where(sliding, friction.friction(v), 0.0)
    return log.with_channels(
        units={"F_m": "N", "friction": "N", "sliding": "1"},
        F_m=base + f,
        friction=f,
        sliding=sliding.astype(float),
    )
