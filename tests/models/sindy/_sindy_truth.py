"""Simulator truth for the SINDy tests (helpers; the fixtures are in conftest.py).

The rig without memory (k2 = 0), so the true force map F_m = A_eff P + F0 - k1 x - k3 x^3 lies in
the library (A_eff 2e-4 m², k1 3000 N/m, k3 2e6 N/m³, F0 0); a 30 s logarithmic chirp 0.2-3 Hz
at 1 kHz drives it through stick-slip and sliding.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hmid.simulate.params import MuscleParams, RigParams

RIG = RigParams(muscle=MuscleParams(k2=0.0))
TRUE = {"x": -3000.0, "P": 2e-4, "x^3": -2e6}  # the true terms and coefficients (SI)
RATE = 1000.0
COLUMNS = ["log", "t", "x", "v", "P"]
SPLIT_T = 21.0  # s: rows before are training rows, after held-out


def true_force(x: np.ndarray, P: np.ndarray) -> np.ndarray:
    m = RIG.muscle
    return m.A_eff * P + m.F0 - m.k1 * x - m.k3 * x**3


def sequences(frame: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """The pipeline's view of one log: sliding rows before SPLIT_T train, after it validate."""
    sliding = ~frame["stuck"].to_numpy()
    late = frame["t"].to_numpy() >= SPLIT_T
    out = frame.assign(F_m=frame["F_true"], train=sliding & ~late, validation=sliding & late)
    return {"chirp": out[["t", "x", "v", "P", "F_m", "train", "validation"]]}


def training_rows(
    truth: pd.DataFrame, seed: int, noise: float = 0.01
) -> tuple[pd.DataFrame, np.ndarray]:
    """Sliding rows before SPLIT_T and the true force plus white noise (sd ``noise`` N)."""
    rows = truth[(~truth["stuck"]) & (truth["t"] < SPLIT_T)]
    rng = np.random.default_rng(seed)
    return rows[COLUMNS], rows["F_true"].to_numpy() + noise * rng.standard_normal(len(rows))
