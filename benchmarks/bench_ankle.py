"""The Ch. 6 ankle's speed (issue 33): a 20 s experiment simulated by hmid's compiled rig (JAX
``lax.scan``, 1 kHz, 10 substeps) beside scipy's ``solve_ivp`` (RK45) on the same plant: the
same fibres, geometry, valves (their openings as an ODE), weights and damping; joint friction off
on both sides (solve_ivp has no stick-slip), the foot kept off its end stops.

Target: a 20 s experiment in < 0.4 s on one core after compilation (>= 50x real time). Both
wall time and the process's CPU time are reported (medians of 5 after a warm-up call): on a
shared machine the wall time holds other processes' turns, the CPU time is the one core's work
(every thread's time counted, so it is no smaller than a single-core run's).
Run: ``.venv/bin/python benchmarks/bench_ankle.py``. Prints a Markdown table.
"""

from __future__ import annotations

import os
import time

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")

import jax
import numpy as np
from scipy.integrate import solve_ivp

from hmid.simulate.rig import integrate
from hmid.simulate.rigs.ankle import Ankle, geometry, plant
from hmid.simulate.rigs.ankle_params import AnkleParams

RATE, SECONDS, SUBSTEPS = 1000.0, 20.0, 10
PARAMS = AnkleParams(coulomb=0.0)
P0 = (3.0e5,) * 5


def commands(n: int) -> np.ndarray:
    """A PWM-like drive: each fibre's duty (fill > 0, vent < 0) a +-12 % sine of its own
    frequency; the foot swings over ~35 deg, off the end stops."""
    t = np.arange(n) / RATE
    return np.stack([0.12 * np.sin(2 * np.pi * (0.4 + 0.13 * i) * t + i) for i in range(5)], 1)


def scipy_run(u: np.ndarray, theta0: float) -> np.ndarray:
    with jax.enable_x64(True):
        c = {k: np.asarray(v) for k, v in plant(PARAMS)._asdict().items()}
    valve = PARAMS.valve
    nf, na = len(c["L0"]), PARAMS.n_active

    def field(time, y):
        th, om, q, P = y[0], y[1], y[2 : 2 + nf], y[2 + nf : 2 + nf + na]
        s_in, s_out = y[2 + nf + na : 2 + nf + 2 * na], y[2 + nf + 2 * na :]
        cmd = u[min(int(time * RATE), len(u) - 1)]
        L, r = geometry(th, c["ox"], c["oy"], c["px"], c["py"], xp=np)
        x = L - c["L0"]
        P_all = np.r_[P, np.zeros(nf - na)]
        T = np.maximum(c["k1"] * x + c["k3"] * x**3 + q - c["A"] * P_all - c["F0"], 0.0)
        weight = c["g"] * c["m_f"] * (c["cx"] * np.cos(th) + c["cy"] * np.sin(th))
        alpha = (np.sum(T * r) + weight - c["damping"] * om) / c["I_f"]
        dq = -q / c["tau"] + c["k2"] * (-r * om)

        def opening(s, want):  # toward the command at the valve's opening / closing speed
            # (within 1 ms of it: hmid's step lands on it exactly, an ODE needs a smooth end)
            return np.clip((want - s) / 1e-3, -1 / valve.closing_time, 1 / valve.opening_time)

        ds_in, ds_out = opening(s_in, np.clip(cmd, 0, 1)), opening(s_out, np.clip(-cmd, 0, 1))
        dP = (s_in * (valve.supply - P) - s_out * P) / valve.line_tau
        return np.r_[om, alpha, dq, dP, ds_in, ds_out]

    y0 = np.r_[theta0, 0.0, np.zeros(nf), P0, np.zeros(2 * na)]
    t = np.arange(1, len(u) + 1) / RATE
    solution = solve_ivp(field, (0.0, t[-1]), y0, t_eval=t, rtol=1e-6, atol=1e-9)
    return solution.y[0]


def timed(fn, repeats: int = 5) -> tuple[float, float]:
    """Median wall and CPU seconds of ``fn()`` over ``repeats`` calls after a warm-up call."""
    fn()
    wall, cpu = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return float(np.median(wall)), float(np.median(cpu))


def main() -> None:
    n = int(RATE * SECONDS)
    u = commands(n)
    rig = Ankle(PARAMS, P0=P0)
    ours, ours_cpu = timed(lambda: integrate(rig, {"valves": u}, RATE, substeps=SUBSTEPS))
    traj = integrate(rig, {"valves": u}, RATE, substeps=SUBSTEPS)
    lo, hi = PARAMS.theta_range
    assert not traj.contact.any(), "the benchmark's drive reached an end stop"
    start, cpu = time.perf_counter(), time.process_time()
    theta = scipy_run(u, float(traj.theta[0]))
    theirs, theirs_cpu = time.perf_counter() - start, time.process_time() - cpu
    gap = np.max(np.abs(traj.theta - theta)) / (hi - lo)
    print("| 20 s ankle experiment | hmid (JAX scan, compiled) | solve_ivp (RK45) | ratio |"
          " real time / hmid | max |Δθ| / range |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for what, a, b in (("wall", ours, theirs), ("CPU", ours_cpu, theirs_cpu)):
        print(f"| {what} time | {a:.3f} s | {b:.1f} s | {b / a:.0f}x | {SECONDS / a:.0f}x | "
              f"{gap:.1e} |")  # fmt: skip
    print(
        f"\ntarget < 0.4 s of one core's work (>= 50x real time): "
        f"{'met' if ours_cpu < 0.4 else 'NOT met'} (CPU {ours_cpu:.3f} s, wall {ours:.3f} s); "
        f"angle range covered {np.degrees(np.ptp(traj.theta)):.0f} deg; "
        f"load average {os.getloadavg()[0]:.1f}"
    )


if __name__ == "__main__":
    main()
