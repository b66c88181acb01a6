"""Moving-average smoothing of sampled signals, as a function and as pluggable strategies.

A moving average of ``N`` samples replaces each sample by the mean of ``N`` neighbours:

* ``mode="centred"`` averages ``h = (N - 1) / 2`` samples either side (``N`` must be odd). It has
  **zero phase lag**: a ramp or a sinusoid comes out in phase with the input. A sinusoid of
  frequency ``f`` sampled every ``dt`` is scaled by the gain
  ``|sin(pi f N dt) / (N sin(pi f dt))|``.
* ``mode="causal"`` averages the current sample and the ``N - 1`` before it, so it can run online,
  but it **delays** the signal: a ramp comes out ``(N - 1) / 2`` samples late, and a sinusoid is
  shifted by ``(N - 1) / 2 * dt`` seconds (same gain as the centred filter).

Edge policy (``edge=``), for the samples where a full window does not fit — the first and last
``h`` samples (centred) or the first ``N - 1`` samples (causal):

* ``"shrink"`` (default): use the samples that exist. The centred window shrinks *symmetrically*
  (sample ``i < h`` is the mean of ``y[0 : 2 i + 1]``, mirrored at the end, so the end samples are
  returned unchanged); the output therefore has no phase shift anywhere and reproduces constant and
  linear signals exactly, edges included. Noise is smoothed less near the ends. The causal window
  shrinks to the samples seen so far (sample ``i < N - 1`` is the mean of ``y[0 : i + 1]``).
* ``"nan"``: NaN in exactly those edge samples, full-window means everywhere else.
* ``"reflect"`` (centred only): the signal is mirrored about its ends (``c b a | a b c``) and the
  full window used everywhere. Good for stationary signals, but it flattens trends at the ends (a
  ramp is biased there). Not offered for the causal filter, where it would read future samples.

Input must be finite: a NaN or inf raises :class:`~hmid.errors.SignalError` naming the first bad
index, so NaN is never smeared over a window silently. A window longer than the signal is also an
error. Means are computed by :func:`scipy.ndimage.uniform_filter1d` (a running sum in C: O(n), about
4 ms for 10⁶ samples, and without the cancellation of a global cumulative sum on long signals).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import ClassVar, Literal, get_args

import numpy as np
from scipy.ndimage import uniform_filter1d

from hmid.errors import SignalError
from hmid.signal._checks import as_signal, as_time, check_fits, median_dt

Mode = Literal["centred", "causal"]
Edge = Literal["shrink", "nan", "reflect"]


@dataclass(frozen=True)
class Window:
    """A window length, given either as a sample count or as a duration (exactly one of the two).

    ``Window(n_samples=51)`` or ``Window(seconds=0.05)``; :meth:`samples` resolves it to a count.
    Functions that take a window also accept a plain ``int`` (a sample count). (The count field
    is ``n_samples``, not ``samples``, because ``samples`` is the resolving method.)
    """

    n_samples: int | None = None
    seconds: float | None = None

    def __post_init__(self) -> None:
        if (self.n_samples is None) == (self.seconds is None):
            raise SignalError(
                f"give exactly one of n_samples and seconds, got n_samples={self.n_samples!r}, "
                f"seconds={self.seconds!r}"
            )
        if self.n_samples is not None:
            n = self.n_samples
            if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
                raise SignalError(f"n_samples must be a positive integer, got {n!r}")
            object.__setattr__(self, "n_samples", int(n))
        else:
            s = self.seconds
            if isinstance(s, bool) or not isinstance(s, int | float | np.floating):
                raise SignalError(f"seconds must be a positive number, got {s!r}")
            if not (math.isfinite(s) and s > 0):
                raise SignalError(f"seconds must be a positive finite number, got {s!r}")
            object.__setattr__(self, "seconds", float(s))

    def samples(self, dt: float | None = None, *, odd: bool = False) -> int:
        """The window as a number of samples.

        A count is returned as given. A duration is divided by the time step ``dt`` (pass the
        *median* step of the log) and rounded to the nearest integer, halves rounding up:
        ``floor(seconds / dt + 0.5)``. With ``odd=True`` (centred filters) a duration that rounds
        to an even count is rounded **up to the next odd** count, while an explicit even count is
        an error — hmid never changes a count you wrote down.
        """
        if self.n_samples is not None:
            n = self.n_samples
            if odd and n % 2 == 0:
                raise SignalError(
                    f"a centred window needs an odd number of samples, got {n}; "
                    f"use {n - 1} or {n + 1}"
                )
            return n
        assert self.seconds is not None  # exactly one of the two (__post_init__)
        if dt is None:
            raise SignalError(
                f"a window of {self.seconds} s needs the time step dt to count samples"
            )
        if not (math.isfinite(dt) and dt > 0):
            raise SignalError(f"time step dt must be positive and finite, got {dt!r}")
        n = math.floor(self.seconds / dt + 0.5)
        if n < 1:
            raise SignalError(
                f"a window of {self.seconds:g} s is shorter than half a time step ({dt:.4g} s); "
                "lengthen the window to at least one time step"
            )
        if odd and n % 2 == 0:
            n += 1
        return n


def as_window(window: Window | int) -> Window:
    """A :class:`Window` from a window or a plain sample count."""
    if isinstance(window, Window):
        return window
    if isinstance(window, int | np.integer) and not isinstance(window, bool):
        return Window(n_samples=int(window))
    raise SignalError(f"window must be a Window or an int sample count, got {window!r}")


def _check_mode_edge(mode: object, edge: object) -> None:
    for value, allowed, what in ((mode, Mode, "mode"), (edge, Edge, "edge")):
        if value not in get_args(allowed):
            raise SignalError(f"{what} must be one of {list(get_args(allowed))}, got {value!r}")
    if edge == "reflect" and mode == "causal":
        raise SignalError(
            "edge='reflect' would make a causal filter read future samples; use 'shrink' or 'nan'"
        )


def _full_means(y: np.ndarray, n: int) -> np.ndarray:
    """``out[j] = mean(y[j : j + n])`` for every full window (length ``len(y) - n + 1``)."""
    # uniform_filter1d centres a window of n samples on index j + n // 2 (odd and even n).
    return uniform_filter1d(y, n, mode="nearest")[n // 2 : n // 2 + y.size - n + 1]


def moving_average(
    y: np.ndarray,
    window: Window | int,
    *,
    mode: Mode = "centred",
    edge: Edge = "shrink",
    dt: float | None = None,
) -> np.ndarray:
    """Moving average of the 1-D signal ``y``; see the module docstring for modes and edges.

    ``dt`` (the median time step) is needed only when ``window`` is given in seconds. Returns a
    new float64 array of the same length as ``y``.
    """
    _check_mode_edge(mode, edge)
    y = as_signal(y)
    n = as_window(window).samples(dt, odd=mode == "centred")
    check_fits(n, y.size, f"a {mode} moving average of {n} samples")
    return _moving_average(y, n, mode, edge)


def _moving_average(y: np.ndarray, n: int, mode: Mode, edge: Edge) -> np.ndarray:
    """:func:`moving_average` of a checked ``y`` over ``n`` samples that fit."""
    if mode == "centred" and edge == "reflect":
        return uniform_filter1d(y, n, mode="reflect")

    out = np.empty_like(y)
    full = _full_means(y, n)
    if mode == "centred":
        h = (n - 1) // 2
        out[h : y.size - h] = full
        if edge == "nan":
            out[:h] = np.nan
            out[y.size - h :] = np.nan
        else:  # shrink: sample i < h is the mean of y[0 : 2i + 1], mirrored at the end
            counts = 2 * np.arange(h) + 1
            out[:h] = np.cumsum(y[: 2 * h])[::2] / counts
            out[y.size - h :] = (np.cumsum(y[::-1][: 2 * h])[::2] / counts)[::-1]
    else:
        out[n - 1 :] = full
        if edge == "nan":
            out[: n - 1] = np.nan
        else:  # shrink: sample i < n - 1 is the mean of y[0 : i + 1]
            out[: n - 1] = np.cumsum(y[: n - 1]) / np.arange(1, n)
    return out


# -- strategies ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Smoother(abc.ABC):
    """A smoothing strategy: ``smoother(t, y)`` returns a smoothed copy of ``y``.

    ``kind`` is the name a config gives the strategy (``denoise.smoother.kind``); messages name
    it rather than the class.
    """

    kind: ClassVar[str] = "smoother"

    @abc.abstractmethod
    def __call__(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Smoothed ``y`` (same length); ``t`` is the strictly increasing time base."""

    def on(self, t: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """The smoother for one time base: ``on(t)(y)`` is ``self(t, y)``, with what depends on
        ``t`` alone checked and computed once (many signals share one time base)."""
        return partial(self, t)

    def local(self, t: np.ndarray) -> tuple[int, Callable[[np.ndarray], np.ndarray]] | None:
        """``(margin, smooth)`` for a filter that reads a bounded neighbourhood: ``smooth(y)``
        smooths any contiguous stretch ``y`` of samples on ``t``'s grid as ``on(t)`` would, and
        equals ``on(t)(whole)`` on that stretch (up to rounding) at samples ``margin`` or more
        from where it was cut out of the whole; a stretch of ``margin`` samples or more fits the
        filter. None for a filter that reads the whole signal (the default)."""
        return None


@dataclass(frozen=True)
class Identity(Smoother):
    """No smoothing: returns a checked copy of ``y``."""

    kind: ClassVar[str] = "identity"

    def __call__(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        y = as_signal(y)
        as_time(t, y.size)
        return y.copy()

    def local(self, t: np.ndarray) -> tuple[int, Callable[[np.ndarray], np.ndarray]]:
        return 0, lambda y: as_signal(y).copy()


@dataclass(frozen=True)
class MovingAverage(Smoother):
    """:func:`moving_average` as a strategy; a window in seconds uses the median step of ``t``.

    ``passes`` applies it that many times: a cascade of moving averages is a B-spline kernel
    (two passes a triangle; three a piecewise quadratic close to a Gaussian of standard deviation
    ``window / 2``) whose derivatives, unlike those of a single box, are smooth enough to
    differentiate the smoothed signal itself. A sample-count window is checked here (an even
    centred count is an error); a window in seconds is resolved per call, since it depends on the
    log's sampling rate.
    """

    kind: ClassVar[str] = "moving_average"
    window: Window | int
    mode: Mode = "centred"
    edge: Edge = "shrink"
    passes: int = 1

    def __post_init__(self) -> None:
        window = as_window(self.window)
        object.__setattr__(self, "window", window)
        _check_mode_edge(self.mode, self.edge)
        if isinstance(self.passes, bool) or not isinstance(self.passes, int) or self.passes < 1:
            raise SignalError(f"passes must be an integer >= 1, got {self.passes!r}")
        if window.n_samples is not None:
            window.samples(odd=self.mode == "centred")

    def __call__(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        y = as_signal(y)
        as_time(t, y.size)
        return self.on(t)(y)

    def on(self, t: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        t = as_time(t, np.size(t))
        n = self._samples(t)

        def smooth(y: np.ndarray) -> np.ndarray:
            y = as_signal(y)
            if y.size != t.size:
                raise SignalError(f"t has {t.size} samples but the signal has {y.size}")
            return self._passes(y, n)

        return smooth

    def local(self, t: np.ndarray) -> tuple[int, Callable[[np.ndarray], np.ndarray]]:
        # each pass reads at most n - 1 samples to one side (centred: (n - 1) / 2 each way)
        n = self._samples(as_time(t, np.size(t)))
        return self.passes * n, lambda y: self._passes(as_signal(y), n)

    def _samples(self, t: np.ndarray) -> int:
        window = as_window(self.window)  # a Window since __post_init__
        dt = median_dt(t) if window.seconds is not None else None
        n = window.samples(dt, odd=self.mode == "centred")
        check_fits(n, t.size, f"a {self.mode} moving average of {n} samples")
        return n

    def _passes(self, y: np.ndarray, n: int) -> np.ndarray:
        for _ in range(self.passes):
            y = _moving_average(y, n, self.mode, self.edge)
        return y
