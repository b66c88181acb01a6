"""Free run (issue 29's speed target): a 40 s log of the demo's SLS muscle on the thesis Ch. 4
rig simulated by hmid's compiled diffrax integrator, beside scipy's ``solve_ivp`` on the same
equation of motion (RK45, same tolerances, the same regularised friction), after compilation.

Target: <= 0.2 s per 40 s log per family on one core, and >= 10x faster than solve_ivp.
Run: ``.venv/bin/python benchmarks/bench_freerun.py``. Prints a Markdown table.
"""

from __future__ import annotations

import os

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")

import numpy as np
from _timing import median_time
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


def main() -> None:
    t = np.arange(int(RATE * SECONDS)) / RATE
    p = pressure(t)
    model = sls_model()
    x0 = (SLS["A_eff"] * p[0] + SLS["F0"] - OFFSET) / SLS["k1"]
    ours = median_time(lambda: model.simulate(t, {"P": p}, x0=x0), repeats=5)
    theirs = median_time(lambda: scipy_run(t, p), repeats=1)
    x_ours = model.simulate(t, {"P": p}, x0=x0).x
    gap = np.max(np.abs(x_ours - scipy_run(t, p))) / np.ptp(x_ours)
    print("| 40 s log, SLS on the Ch. 4 rig | hmid (diffrax Tsit5, compiled) | solve_ivp (RK45) |"
          " ratio | max |Δx| / range |")  # fmt: skip
    print("|---|---|---|---|---|")
    print(f"| free run | {ours:.3f} s | {theirs:.2f} s | {theirs / ours:.0f}x | {gap:.1e} |")
    print(f"\ntarget <= 0.2 s: {'met' if ours <= 0.2 else 'NOT met'}; "
          f">= 10x solve_ivp: {'met' if theirs / ours >= 10 else 'NOT met'}")  # fmt: skip


if __name__ == "__main__":
    main()
