"""Synthetic pneumatic-cylinder data with a known extra effect (formulas, no simulator), the
cylinder declared as a rig, and the loop run on its balance fit."""

import numpy as np
import pandas as pd

from hmid.balance import RigSection, Signals
from hmid.families import FitContext, FitData
from hmid.families.balance import BalanceSpec
from hmid.loop import LoopBase, Setting, run_loop

A, F0, FC = 5.0e-4, 0.3, 4.0  # m², N, N
RATE = 200.0  # Hz
NOISE = 0.05  # N
UNITS = {"x": "m", "P": "Pa", "v": "m/s", "a": "m/s^2", "target": "N"}
#: Rod force = A P + F0 - Fc sign(v): friction subtracts from the reading
PISTON = RigSection.model_validate(
    {
        "channels": {"x": {}, "P": {}},
        "position": "x",
        "explained": "F",
        "balance": [
            {"kind": "channel", "name": "A", "channel": "P", "positive": True},
            {"kind": "constant", "name": "F0"},
            {"kind": "coulomb", "name": "Fc", "sign": -1},
        ],
    }
)


def motion(seed: int, segments: int = 4, seconds: float = 20.0):
    """x, v, P, t per segment: strokes at varying speed, pressure wandering slowly."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, seconds, 1 / RATE)
    rows = []
    for k in range(segments):
        f1, f2 = rng.uniform(0.2, 0.6), rng.uniform(0.7, 1.5)
        x = 0.02 * np.sin(2 * np.pi * f1 * t) + 0.005 * np.sin(2 * np.pi * f2 * t + k)
        v = 0.02 * 2 * np.pi * f1 * np.cos(2 * np.pi * f1 * t) + 0.005 * 2 * np.pi * f2 * np.cos(
            2 * np.pi * f2 * t + k
        )
        P = 3e5 + 1.5e5 * np.sin(2 * np.pi * rng.uniform(0.3, 0.8) * t + k)
        rows.append(pd.DataFrame({"segment": k, "t": t, "x": x, "v": v, "P": P, "a": 0.0}))
    return pd.concat(rows, ignore_index=True)


def make_data(effect=None, seed: int = 0, **kwargs) -> tuple[Signals, dict]:
    """Rod force = A P + F0 - Fc sign(v) (+ the effect) + white noise, 30 % of each segment
    held out at its end; ``effect`` is a function of the frame returning (force, truth)."""
    frame = motion(seed, **kwargs)
    y = A * frame["P"] + F0 - FC * np.sign(frame["v"])
    truth = {}
    if effect is not None:
        extra, truth = effect(frame)
        y = y + extra
    y = y + np.random.default_rng(seed + 1000).normal(0, NOISE, len(frame))
    position = frame.groupby("segment").cumcount() / frame.groupby("segment")["t"].transform("size")
    moving = np.abs(frame["v"]) > 1e-3
    frame = frame.assign(
        log=frame["segment"].map(lambda k: f"log{k}"),
        target=y,
        usable=moving,
        train=(position < 0.7) & moving,
        validation=(position >= 0.7) & moving,
    )
    return Signals.from_frame(frame, UNITS, position="x"), truth


def loop_on(signals: Signals, spec, rig: RigSection = PISTON, tmp=None):
    """The balance family fitted on ``signals``, then the loop on it."""
    data = FitData(signals, rig)
    (fitted,) = BalanceSpec().fit(data, FitContext(0, tmp))
    return run_loop(signals, LoopBase.of(fitted, data), spec, Setting.of(rig))
