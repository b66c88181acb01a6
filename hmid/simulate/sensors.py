"""Sensor chain of the rig: true signal -> effect on the sensor -> noise -> glitches -> 10-bit ADC.

The logger stores engineering values on the ADC grid (``lo + counts * lsb``), as the thesis's
microcontroller did, or the raw counts. Values beyond the sensor's span saturate at the ADC rails,
which the loader later flags. Glitches: single-sample spikes (a random count, like an EMI hit) and
dropped samples (rows missing from the log, as when a serial logger misses a frame).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from hmid.simulate.effects import Effect
from hmid.simulate.params import Glitches, SensorSpec


def adc_counts(values: np.ndarray, spec: SensorSpec) -> np.ndarray:
    """Round to the nearest ADC count, saturating at 0 and 2**bits - 1."""
    counts = np.floor((values - spec.lo) / spec.lsb + 0.5)
    return np.clip(counts, 0, 2**spec.bits - 1).astype(np.int64)


def measure(
    t: np.ndarray,
    truth: Mapping[str, np.ndarray],
    specs: Mapping[str, SensorSpec],
    glitches: Glitches,
    effects: tuple[Effect, ...],
    rng: np.random.Generator,
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Counts for each sensed channel, and the mask of samples the logger kept.

    Draw order is fixed (noise per channel in ``specs`` order, then spikes, then dropouts), so a
    log depends only on the generator's seed.
    """
    counts = {}
    for name, spec in specs.items():
        y = np.asarray(truth[name], dtype=float)
        for effect in effects:
            y = effect.sense(name, t, y)
        y = y + spec.noise * rng.standard_normal(len(y))
        c = adc_counts(y, spec)
        spikes = rng.random(len(c)) < glitches.spike_rate
        c[spikes] = rng.integers(0, 2**spec.bits, size=int(spikes.sum()))
        counts[name] = c
    keep = rng.random(len(t)) >= glitches.dropout_rate
    keep[0] = keep[-1] = True  # the log's span stays as commanded
    return counts, keep


def to_values(counts: np.ndarray, spec: SensorSpec) -> np.ndarray:
    """Engineering value (SI) of ADC counts."""
    return spec.lo + counts * spec.lsb
