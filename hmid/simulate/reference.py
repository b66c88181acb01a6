"""Band-limited random position references for the positioning stage.

White noise from the log's generator through a zero-phase order-4 Butterworth low-pass, faded in
over the first ``fade_in`` seconds (so the stage starts at rest at x = 0) and scaled to the
target RMS. The noise is drawn with margins beyond both ends and cropped, so the filter's start-up
transients never reach the log.
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from pydantic import Field
from scipy.signal import butter, sosfiltfilt

from hmid.simulate.params import _Frozen


class RandomReference(_Frozen):
    """A random position reference: RMS (m) and low-pass cutoff (Hz)."""

    rms: Annotated[float, Field(gt=0, le=10)] = 0.02  # m
    cutoff_hz: Annotated[float, Field(gt=0)] = 2.0
    fade_in: Annotated[float, Field(ge=0)] = 0.5  # s, sin^2 ramp from 0

    def positions(self, n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
        """``n`` reference positions at ``rate`` Hz, starting at exactly 0."""
        sos = butter(4, self.cutoff_hz, fs=rate, output="sos")
        margin = int(np.ceil(5 * rate / self.cutoff_hz))  # ~ 5 periods of the cutoff
        y = sosfiltfilt(sos, rng.standard_normal(n + 2 * margin))[margin : margin + n]
        t = np.arange(n) / rate
        ramp = np.clip(t / self.fade_in, 0.0, 1.0) if self.fade_in > 0 else np.ones(n)
        y = y * np.sin(0.5 * np.pi * ramp) ** 2  # smooth: zero slope at both ends of the fade
        return y * (self.rms / np.sqrt(np.mean(y**2)))
