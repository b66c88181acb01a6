"""Free run (issue 29's speed target): 40 s logs simulated by hmid's compiled diffrax integrator,
beside scipy's ``solve_ivp`` on the same equation of motion (the same tolerances, rtol 1e-6 and
atol 1e-9, the same regularised friction), after compilation: the demo's SLS muscle on the
thesis Ch. 4 rig (a memory arm, x^3, a pressure input at 500 Hz) and a balance model of a
linear-motor stage (M a + c v + Fc sign(v) = u, a random drive force at 1 kHz), the stage both
at the fit's cut-off v0 = 2 mm/s (a model file without a sample rate) and at the free run's own
v0 = dt Fc / (2 M) (1.04 mm/s: stiffer near v = 0, as a shipped run integrates it). scipy runs
RK45 (explicit, as hmid's Tsit5) and its stiff methods Radau and LSODA (Jacobians by finite
differences, as a user would call them); the table shows RK45 and the faster stiff one. Timings
interleave the sides (each repeat runs hmid, then each scipy method), medians of 3 after a
warm-up, in wall time and in the process's CPU time (the ratios of the second are steadier on
a loaded machine).

Accuracy: each side's largest miss of a tight solution of its own equation (solve_ivp DOP853 at
rtol 1e-10, atol 1e-13), as a share of the position's range: hmid's against the input read as
hmid reads it (a Catmull-Rom cubic between samples), RK45's against the input read linearly, as
its timed run reads it (the two readings' solutions differ: each side is held to its own
equation; the linear reading's kinks make its tight solve slow, ~40 s a row).

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


#: The references: DOP853 at rtol 1e-10, atol 1e-13, the input read as hmid reads it, or
#: linearly (the timed scipy methods' reading, so that their miss of it is their error)
TIGHT, TIGHT_LINEAR = "tight", "tight, linear"


def catmull_rom(t: np.ndarray, values: np.ndarray):
    """``values`` at a time, read as hmid's free run reads an input on a regular grid ``t``: a
    cubic Hermite between samples with Catmull-Rom slopes (one-sided at the ends)."""
    n, dt = len(values), t[1] - t[0]

    def at(time: float) -> float:
        s = (time - t[0]) / dt
        k = min(max(int(np.floor(s)), 0), n - 2)
        w, y0, y1 = s - k, values[k], values[k + 1]
        m0 = (y1 - values[max(k - 1, 0)]) / (2.0 if k > 0 else 1.0)
        m1 = (values[min(k + 2, n - 1)] - y0) / (2.0 if k + 2 <= n - 1 else 1.0)
        return ((2 * w**3 - 3 * w**2 + 1) * y0 + (w**3 - 2 * w**2 + w) * m0
                + (-2 * w**3 + 3 * w**2) * y1 + (w**3 - w**2) * m1)  # fmt: skip

    return at


def reading(t: np.ndarray, values: np.ndarray, method: str):
    """The input as a function of time: linear (``np.interp``, what a scipy user writes) for
    the timed methods; for :data:`TIGHT`, read as hmid reads it (:func:`catmull_rom`)."""
    if method == TIGHT:
        return catmull_rom(t, values)
    return lambda time: np.interp(time, t, values)


def options(method: str) -> dict:
    if method in (TIGHT, TIGHT_LINEAR):
        return {"method": "DOP853", "rtol": 1e-10, "atol": 1e-13}
    return {"method": method, "rtol": 1e-6, "atol": 1e-9}


def scipy_run(t: np.ndarray, p: np.ndarray, method: str = "RK45") -> np.ndarray:
    pressure_at = reading(t, p, method)

    def field(time, y):
        x, v, q = y
        P = pressure_at(time)
        force = SLS["A_eff"] * P + SLS["F0"] - SLS["k1"] * x - SLS["k3"] * x**3 - SLS["k2"] * q
        a = (force - FC * np.tanh(v / V0) - OFFSET) / M
        return [v, a, -q / SLS["tau"] + v]

    x0 = (SLS["A_eff"] * p[0] + SLS["F0"] - OFFSET) / SLS["k1"]
    solution = solve_ivp(field, (t[0], t[-1]), [x0, 0.0, 0.0], t_eval=t, **options(method))
    return solution.y[0]


STAGE = {"M": 1.2, "c": 8.0, "Fc": 2.5}


def stage_model(rate: float | None = None) -> Model:
    """A linear-motor stage's balance model: the drive force u explained by M a + c v + Fc
    sign(v) (a family ``balance`` fit's form), friction regularised at 2 mm/s, or with the
    sample ``rate`` at the free run's own v0 = Fc / (2 M rate)."""
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
    } | ({"sample_rate_hz": rate} if rate else {}))  # fmt: skip


def drive(t: np.ndarray) -> np.ndarray:
    """A random drive force: white noise low-passed to ~2 Hz, 10 N RMS (seeded)."""
    from scipy.signal import butter, filtfilt

    b, a = butter(2, 2.0 / 500.0)
    u = filtfilt(b, a, np.random.default_rng(0).normal(size=len(t)))
    return 10.0 * u / np.std(u)


def scipy_stage(t: np.ndarray, u: np.ndarray, method: str = "RK45", v0: float = V0) -> np.ndarray:
    drive_at = reading(t, u, method)

    def field(time, y):
        _, v = y
        force = drive_at(time) - STAGE["c"] * v - STAGE["Fc"] * np.tanh(v / v0)
        return [v, force / STAGE["M"]]

    solution = solve_ivp(field, (t[0], t[-1]), [0.0, 0.0], t_eval=t, **options(method))
    return solution.y[0]


def interleaved(*fns, repeats: int = 3) -> list[tuple[float, float]]:
    """Median (wall, CPU) times of each of ``fns``, run in turn after a warm-up of each."""
    for fn in fns:
        fn()
    walls: list[list[float]] = [[] for _ in fns]
    cpus: list[list[float]] = [[] for _ in fns]
    for _ in range(repeats):
        for fn, wall, cpu in zip(fns, walls, cpus, strict=True):
            start, start_cpu = time.perf_counter(), time.process_time()
            fn()
            wall.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
    return [(statistics.median(w), statistics.median(c)) for w, c in zip(walls, cpus, strict=True)]


STIFF = ("Radau", "LSODA")


def row(name: str, ours, theirs, x_ours: np.ndarray) -> tuple[str, str, float, float]:
    """``ours()`` beside ``theirs(method)`` for RK45 and each of :data:`STIFF`: a table row (wall
    times), a line of CPU-time ratios, hmid's wall time and its least ratio."""
    methods = ("RK45", *STIFF)
    times = interleaved(ours, *[lambda m=m: theirs(m) for m in methods])
    (wall, cpu), rest = times[0], dict(zip(methods, times[1:], strict=True))
    stiff = min(STIFF, key=lambda m: rest[m][0])
    tight, scale = theirs(TIGHT), np.ptp(x_ours)
    miss = np.max(np.abs(x_ours - tight)) / scale
    # RK45 beside the tight solution of its own input reading (linear): its integration error
    rk45 = np.max(np.abs(theirs("RK45") - theirs(TIGHT_LINEAR))) / scale
    line = (
        f"| {name} | {wall:.3f} s | {rest['RK45'][0]:.2f} s | {rest['RK45'][0] / wall:.1f}x "
        f"| {stiff} {rest[stiff][0]:.2f} s | {rest[stiff][0] / wall:.1f}x | {miss:.1e} "
        f"| {rk45:.1e} |"
    )
    cpus = ", ".join(f"{m} {rest[m][1] / cpu:.1f}x" for m in methods)
    least = min(rest["RK45"][0], rest[stiff][0]) / wall
    return line, f"{name}: hmid {cpu * 1e3:.0f} ms of CPU; {cpus}", wall, least


def main() -> None:
    print("| 40 s log | hmid (Tsit5, compiled) | solve_ivp RK45 | ratio | solve_ivp stiff, best "
          "| ratio | miss of a tight solution: hmid | RK45 |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    lines, met = [], []
    t = np.arange(int(RATE * SECONDS)) / RATE
    p = pressure(t)
    model = sls_model()
    x0 = (SLS["A_eff"] * p[0] + SLS["F0"] - OFFSET) / SLS["k1"]
    x_ours = model.simulate(t, {"P": p}, x0=x0).x
    line, cpu, wall, ratio = row("SLS, Ch. 4 rig, 500 Hz",
                                 lambda: model.simulate(t, {"P": p}, x0=x0),
                                 lambda m: scipy_run(t, p, m), x_ours)  # fmt: skip
    print(line, flush=True)
    lines.append(cpu)
    met.append((wall, ratio))
    t = np.arange(int(1000 * SECONDS)) / 1000.0
    u = drive(t)
    for name, rate in (("v0 2 mm/s", None), ("v0 dt Fc/(2M)", 1000.0)):
        stage = stage_model(rate)
        v0 = stage.simulator.equation.v0
        x_ours = stage.simulate(t, {"u": u}, x0=0.0).x
        line, cpu, wall, ratio = row(f"balance, linear-motor stage, 1 kHz, {name}",
                                     lambda s=stage: s.simulate(t, {"u": u}, x0=0.0),
                                     lambda m, v0=v0: scipy_stage(t, u, m, v0), x_ours)  # fmt: skip
        print(line, flush=True)
        lines.append(cpu)
        met.append((wall, ratio))
    print("\nCPU-time ratios (process time):")
    for cpu in lines:
        print(f"- {cpu}")
    print(
        f"\ntarget <= 0.2 s: {'met' if all(o <= 0.2 for o, _ in met) else 'NOT met'}; "
        f">= 10x solve_ivp (RK45 and the best stiff): "
        f"{'met' if all(r >= 10 for _, r in met) else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
