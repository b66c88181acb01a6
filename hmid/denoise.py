"""Denoising stage: smoothed P, x, F and estimated velocity and acceleration, as new channels."""

from __future__ import annotations

from hmid.io.log import Log
from hmid.signal import Differentiator, Smoother, estimate_motion


def denoise_log(log: Log, smoother: Smoother, differentiator: Differentiator) -> Log:
    """A copy of ``log`` with ``<c>_s`` (smoothed) for each of P, x, F present, and v, a from x.

    Velocity and acceleration come from the raw x through ``differentiator`` (which smooths on
    its own terms), not from the smoothed x, so the two filters do not compound their lag.
    """
    t = log.t
    smoothed = {f"{c}_s": smoother(t, log[c]) for c in ("P", "x", "F") if c in log}
    units = {f"{c}_s": log.units[c] for c in ("P", "x", "F") if c in log}
    if "x" in log:
        v, a = estimate_motion(t, log["x"], differentiator)
        smoothed |= {"v": v, "a_est": a}
        units |= {"v": "m/s", "a_est": "m/s^2"}
    return log.with_channels(units=units, **smoothed)
