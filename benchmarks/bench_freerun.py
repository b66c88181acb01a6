"""Free run (issue 29's speed target): 40 s logs simulated by hmid's compiled diffrax integrator,
beside scipy's ``solve_ivp`` on the same equation of motion (RK45, same tolerances, the same
regularised friction), after compilation: the demo's SLS muscle on the thesis Ch. 4 rig (a
memory arm, x^3, a pressure input at 500 Hz) and a balance model of a linear-motor stage
(M a + c v + Fc sign(v) = u, a random drive force at 1 kHz). Timings interleave the two sides
(each repeat runs hmid, then scipy), medians of 3 after a warm-up.

Target: <= 0.2 s per 40 s log per family on one core, and >= 10x faster than solve_ivp.
Run: ``.venv/bin/python benchmarks/bench_freerun.py``. Prints a Markdown table.
"""

from __future__ import annotations

import os

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")

import statistics
import time

import numpy as np
from scipy.integrate import solve_ivp

from hmid.portable import Model
from hmid.portable.file import FORMAT

RATE, SECONDS = 500.0, 40.0
M, OFFSET, FC, V0 = 0.75, 4.903325, 0.5, 0.002
SLS = {"A_eff": 2e-4, "F0": 0.04, "k1": 3000.0, "k3": 2e6, "k2": 1500.0, "tau": 0.2}


def sls_model() -> Model:
    terms = [
        {"kind": "channel", "name": "A_eff", "channel": "P", "sign": 1},
        {"kind": "constant", "name": "F0", "sign": 1},
        {"kind": "channel", "name": "k1", "channel": "x", "sign": -1},
        {"kind": "channel", "name": "k3", "channel": "x^3", "sign": -1},
        {"kind": "memory", "name": "k2", "channel": "x", "sign": -1, "tau": SLS["tau"]},
    ]
    rig = {
        "name": "Ch. 4 rig", "channels": {"x": {}, "P": {}}, "position": "x", "explained": "F",
        "balance": [{"kind": "model", "name": "F_m"},
                    {"kind": "coulomb", "name": "Fc", "sign": -1, "from": "free_fall"}],
        "free_fall": {"mass": M, "drive": OFFSET}, "motion": {"mass": M, "offset": OFFSET},
    }  # fmt: skip
    return Model({
        "format": FORMAT, "name": "sls", "family": "sls", "rig": rig,
        "units": {"x": "m", "P": "Pa", "F": "N", "v": "m/s", "a": "m/s^2", "target": "N"},
        "denoise": {}, "fit": {"v_deadband": V0},
        "known": {"free_fall_friction": {"Fc": FC, "b": 0.0}},
        "terms": terms, "coefficients": {"names": [t["name"] for t in terms],
                                         "values": [SLS[t["name"]] for t in terms]},
    })  # fmt: skip


def pressure(t: np.ndarray) -> np.ndarray:
    """A chirp 0.2 -> 3 Hz between 0 and 100 kPa."""
    phase = 2 * np.pi * (0.2 * t + (3.0 - 0.2) / (2 * SECONDS) * t**2)
    return 5e4 * (1 - np.cos(phase))


def scipy_run(t: np.ndarray, p: np.ndarray) -> np.ndarray:
    def field(time, y):
        x, v, q = y
        P = np.interp(time, t, p)
        force = SLS["A_eff"] * P + SLS["F0"] - SLS["k1"] * x - SLS["k3"] * x**3 - SLS["k2"] * q
        a = (force - FC * np.tanh(v / V0) - OFFSET) / M
        return [v, a, -q / SLS["tau"] + v]

    x0 = (SLS["A_eff"] * p[0] + SLS["F0"] - OFFSET) / SLS["k1"]
    solution = solve_ivp(field, (t[0], t[-1]), [x0, 0.0, 0.0], t_eval=t, rtol=1e-6, atol=1e-9)
    return solution.y[0]


STAGE = {"M": 1.2, "c": 8.0, "Fc": 2.5}


def stage_model() -> Model:
    """A linear-motor stage's balance model: the drive force u explained by M a + c v + Fc
    sign(v) (a family ``balance`` fit's form), friction regularised at 2 mm/s."""
    terms = [
        {"kind": "channel", "name": "M", "channel": "a", "sign": 1},
        {"kind": "channel", "name": "c", "channel": "v", "sign": 1},
        {"kind": "coulomb", "name": "Fc", "sign": 1},
    ]
    rig = {
        "name": "stage", "channels": {"x": {}, "u": {}}, "position": "x", "explained": "u",
        "balance": [dict(t, value=None) for t in terms],
    }  # fmt: skip
    return Model({
        "format": FORMAT, "name": "balance", "family": "balance", "rig": rig,
        "units": {"x": "m", "u": "N", "v": "m/s", "a": "m/s^2", "target": "N"},
        "denoise": {}, "fit": {"v_deadband": V0}, "known": {"free_fall_friction": None},
        "terms": terms, "coefficients": {"names": [t["name"] for t in terms],
                                         "values": [STAGE[t["name"]] for t in terms]},
    })  # fmt: skip


def drive(t: np.ndarray) -> np.ndarray:
    """A random drive force: white noise low-passed to ~2 Hz, 10 N RMS (seeded)."""
    from scipy.signal import butter, filtfilt

    b, a = butter(2, 2.0 / 500.0)
    u = filtfilt(b, a, np.random.default_rng(0).normal(size=len(t)))
    return 10.0 * u / np.std(u)


def scipy_stage(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    def field(time, y):
        _, v = y
        force = np.interp(time, t, u) - STAGE["c"] * v - STAGE["Fc"] * np.tanh(v / V0)
        return [v, force / STAGE["M"]]

    solution = solve_ivp(field, (t[0], t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-6, atol=1e-9)
    return solution.y[0]


def interleaved(ours, theirs, repeats: int = 3) -> tuple[float, float]:
    """Median wall times of ``ours()`` and ``theirs()``, run in turn after a warm-up of each."""
    ours(), theirs()
    walls: tuple[list[float], list[float]] = ([], [])
    for _ in range(repeats):
        for fn, wall in ((ours, walls[0]), (theirs, walls[1])):
            start = time.perf_counter()
            fn()
            wall.append(time.perf_counter() - start)
    return statistics.median(walls[0]), statistics.median(walls[1])


def main() -> None:
    print("| 40 s log | hmid (diffrax Tsit5, compiled) | solve_ivp (RK45) | ratio |"
          " max |Δx| / range |")  # fmt: skip
    print("|---|---|---|---|---|")
    met = []
    t = np.arange(int(RATE * SECONDS)) / RATE
    p = pressure(t)
    model = sls_model()
    x0 = (SLS["A_eff"] * p[0] + SLS["F0"] - OFFSET) / SLS["k1"]
    ours, theirs = interleaved(lambda: model.simulate(t, {"P": p}, x0=x0),
                               lambda: scipy_run(t, p))  # fmt: skip
    x_ours = model.simulate(t, {"P": p}, x0=x0).x
    gap = np.max(np.abs(x_ours - scipy_run(t, p))) / np.ptp(x_ours)
    print(f"| SLS, Ch. 4 rig, 500 Hz | {ours:.3f} s | {theirs:.2f} s | {theirs / ours:.1f}x "
          f"| {gap:.1e} |")  # fmt: skip
    met.append((ours, theirs / ours))
    t = np.arange(int(1000 * SECONDS)) / 1000.0
    u = drive(t)
    stage = stage_model()
    ours, theirs = interleaved(lambda: stage.simulate(t, {"u": u}, x0=0.0),
                               lambda: scipy_stage(t, u))  # fmt: skip
    x_ours = stage.simulate(t, {"u": u}, x0=0.0).x
    gap = np.max(np.abs(x_ours - scipy_stage(t, u))) / np.ptp(x_ours)
    print(f"| balance, linear-motor stage, 1 kHz | {ours:.3f} s | {theirs:.2f} s "
          f"| {theirs / ours:.1f}x | {gap:.1e} |")  # fmt: skip
    met.append((ours, theirs / ours))
    print(
        f"\ntarget <= 0.2 s: {'met' if all(o <= 0.2 for o, _ in met) else 'NOT met'}; "
        f">= 10x solve_ivp: {'met' if all(r >= 10 for _, r in met) else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
