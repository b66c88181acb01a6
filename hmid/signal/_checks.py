"""Input checks shared by the smoothers and differentiators (private).

Every check raises :class:`~hmid.errors.SignalError` with a one-line message that names the array,
the first offending index and what to do about it. Nothing here copies data it does not have to.
"""

from __future__ import annotations

import numpy as np

from hmid.errors import SignalError

#: Time steps checked at a time (:func:`as_time`)
CHECK_BLOCK = 1 << 20


def as_signal(y: object, name: str = "y") -> np.ndarray:
    """``y`` as a 1-D float64 array whose samples are all finite."""
    arr = np.asarray(y, dtype="float64")
    if arr.ndim != 1:
        raise SignalError(f"{name} must be 1-D, got shape {arr.shape}")
    finite = np.isfinite(arr)
    if not finite.all():
        i = int(np.argmin(finite))
        raise SignalError(
            f"{name}[{i}] is {arr[i]}; the signal must be finite everywhere "
            "(drop or interpolate bad samples before filtering)"
        )
    return arr


def as_time(t: object, n: int) -> np.ndarray:
    """``t`` as a finite, strictly increasing 1-D float64 array of length ``n``."""
    arr = as_signal(t, "t")
    if arr.shape != (n,):
        raise SignalError(f"t has {arr.size} samples but the signal has {n}")
    for lo in range(0, n - 1, CHECK_BLOCK):  # the steps of a long log by blocks: no copy of t
        bad = np.diff(arr[lo : lo + CHECK_BLOCK + 1]) <= 0
        if bad.any():
            i = lo + int(np.argmax(bad))
            raise SignalError(
                f"t must increase strictly, but t[{i + 1}]={arr[i + 1]!r} <= t[{i}]={arr[i]!r}"
            )
    return arr


def median_dt(t: np.ndarray) -> float:
    """Median time step of a checked time base (needs at least two samples)."""
    if t.size < 2:
        raise SignalError(f"need at least 2 time samples to find the time step, got {t.size}")
    return float(np.median(np.diff(t), overwrite_input=True))  # its own diff: no copy


def check_fits(needed: int, n: int, what: str) -> None:
    """Raise if a window of ``needed`` samples does not fit in a signal of ``n`` samples."""
    if needed > n:
        raise SignalError(
            f"{what} needs {needed} samples but the signal has only {n}; "
            "shorten the window or use a longer log"
        )
