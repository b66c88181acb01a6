"""Denoising stage: smoothed P, x, F and estimated velocity and acceleration, as new channels."""

from __future__ import annotations

from hmid.errors import LogError, SignalError
from hmid.io.log import Log
from hmid.signal import Differentiator, Smoother, estimate_motion


def denoise_log(log: Log, smoother: Smoother, differentiator: Differentiator) -> Log:
    """A copy of ``log`` with ``<c>_s`` (smoothed) for each of P, x, F present, and v, a from x.

    Velocity and acceleration come from the raw x through ``differentiator`` (which smooths on
    its own terms), not from the smoothed x, so the two filters do not compound their lag. A log
    too short for the windows (or otherwise unfit for them) is a :class:`LogError` naming it.
    """
    t = log.t
    channels, units = {}, {}
    step = "smoothing"
    try:
        for c in ("P", "x", "F"):
            if c in log:
                channels[f"{c}_s"], units[f"{c}_s"] = smoother(t, log[c]), log.units[c]
        if "x" in log:
            step = "differentiating"
            v, a = estimate_motion(t, log["x"], differentiator)
            channels |= {"v": v, "a_est": a}
            units |= {"v": "m/s", "a_est": "m/s^2"}
    except SignalError as err:
        raise LogError(
            f"{log.source}: {step} failed: {err}; use a longer log or shorter windows "
            "in the config's denoise section"
        ) from None
    return log.with_channels(units=units, **channels)
