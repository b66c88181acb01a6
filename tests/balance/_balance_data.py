"""Synthetic signals for the balance tests (imported by name): known x(t), v, a, P per segment."""

import numpy as np
import pandas as pd

from hmid.balance import Signals

UNITS = {"x": "m", "P": "Pa", "v": "m/s", "a": "m/s^2", "target": "N"}
RATE = 500.0


def motion(seed: int = 0, segments: int = 3, seconds: float = 12.0) -> pd.DataFrame:
    """x = sum of two sines per segment (exact v and a), P wandering; 30 % of each segment held
    out at its end."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, seconds, 1 / RATE)
    parts = []
    for k in range(segments):
        (f1, f2), phase = rng.uniform([0.2, 0.8], [0.6, 1.6]), rng.uniform(0, 2 * np.pi)
        w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
        x = 0.01 + 0.008 * np.sin(w1 * t) + 0.002 * np.sin(w2 * t + phase)
        v = 0.008 * w1 * np.cos(w1 * t) + 0.002 * w2 * np.cos(w2 * t + phase)
        a = -0.008 * w1**2 * np.sin(w1 * t) - 0.002 * w2**2 * np.sin(w2 * t + phase)
        P = 2e5 + 1e5 * np.sin(2 * np.pi * rng.uniform(0.3, 0.7) * t + k)
        late = t >= 0.7 * seconds
        parts.append(
            pd.DataFrame(
                {
                    "log": f"log{k}",
                    "segment": k,
                    "t": t,
                    "x": x,
                    "v": v,
                    "a": a,
                    "P": P,
                    "train": ~late,
                    "validation": late,
                }
            )
        )
    return pd.concat(parts, ignore_index=True)


def signals_with(target: np.ndarray | None = None, seed: int = 0, **kw) -> Signals:
    frame = motion(seed, **kw)
    frame["target"] = 0.0 if target is None else target
    return Signals.from_frame(frame, UNITS, position="x")
