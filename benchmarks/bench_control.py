"""Closed-loop control (issue 33's speed target): a 20 s experiment of the Hydro Muscle on the
thesis Ch. 4 rig under the model-based controller (inverse-dynamics feed-forward + PD, 1 kHz),
simulated by hmid's compiled closed loop (one jitted scan, 20 substeps per sample) beside scipy's
``solve_ivp`` on the same plant (RK45, rtol 1e-8, restarted at every sample where the controller
sets the valve), after compilation.

The plant is the rig without friction (stick-slip has no ODE form for ``solve_ivp``) and the
controller the same PD and feed-forward, so the two runs must agree; the table says by how much.
Target: >= 50x faster than real time on one core (a 20 s experiment in < 0.4 s).
Run: ``.venv/bin/python benchmarks/bench_control.py``. Prints a Markdown table.
"""

from __future__ import annotations

import os

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")

import time

import numpy as np
from _timing import median_time
from scipy.integrate import solve_ivp

from hmid.control import ForceLaw, MuscleRig, feedforward, reference, track, tune
from hmid.simulate.params import FrictionParams, RigParams

SECONDS, RATE, TAU_V = 20.0, 1000.0, 0.03
RIG = RigParams(friction=FrictionParams(F_block=0.0, F_pulley=0.0))


def scipy_closed_loop(tuning, ff, ref, x0: float, P0: float) -> np.ndarray:
    """The same plant and controller, the plant by solve_ivp between samples."""
    m, c = RIG.muscle, RIG
    mass = c.M + c.m1
    slew, tau_v = c.valve.slew, c.valve.tau
    a = np.exp(-tuning.dt / tuning.tf)

    def field(_, y, u):
        x, v, q, P = y
        force = m.A_eff * P + m.F0 - (m.k1 * x + m.k3 * x**3 + q) - c.m1 * c.g
        dP = np.clip((u - P) / tau_v, -slew, slew)
        return [v, force / mass, -q / m.tau + m.k2 * v, dP]

    y = np.array([x0, 0.0, 0.0, P0])
    last, rate, out = None, 0.0, []
    step = 0.02048 / 1024
    for k in range(len(ff.commands)):
        measured = np.round(y[0] / step) * step
        error = ref.y[k] - measured
        last = error if last is None else last
        rate = a * rate + (1 - a) * (error - last) / tuning.dt
        last = error
        u = np.clip(ff.commands[k] + tuning.kp * error + tuning.kd * rate, 0.0, 6.0e5)
        sol = solve_ivp(field, (0.0, tuning.dt), y, args=(u,), rtol=1e-8, atol=1e-12)
        y = sol.y[:, -1]
        out.append(y[0])
    return np.array(out)


def main() -> None:
    law = ForceLaw.of_rig(RIG)
    plant = MuscleRig(RIG, "position")
    t = np.arange(0, round(SECONDS * RATE) + 1) / RATE
    ref = reference("gait", t, 0.004, 0.009, frequency=1.0)
    tuning = tune(plant.linear(law, ref, TAU_V), 1 / RATE)
    ff = feedforward(plant, law, ref, "FF+PD", TAU_V)
    hmid_t = median_time(lambda: track(plant, tuning, ff, ref, "FF+PD"), 5)
    run = track(plant, tuning, ff, ref, "FF+PD")
    x0 = float(plant.outputs(ff.start)["x"])
    start = time.perf_counter()
    x_scipy = scipy_closed_loop(tuning, ff, ref, x0, ff.start)
    scipy_t = time.perf_counter() - start
    agree = float(np.max(np.abs(x_scipy - run.output)))
    stick = median_time(lambda: track(MuscleRig(RigParams(), "position"), tuning, ff, ref,
                                      "FF+PD"), 5)  # fmt: skip
    print("| what | hmid (s) | solve_ivp (s) | ratio | real time x | note |")
    print("|---|---:|---:|---:|---:|---|")
    print(f"| {SECONDS:g} s closed loop, FF+PD at 1 kHz, frictionless rig | {hmid_t:.3f} | "
          f"{scipy_t:.2f} | {scipy_t / hmid_t:.0f}x | {SECONDS / hmid_t:.0f}x | "
          f"max abs x diff {agree:.1e} m |")  # fmt: skip
    met = "met" if SECONDS / stick >= 50 else "not met"
    print(f"| the same with the rig's stick-slip friction | {stick:.3f} | | | "
          f"{SECONDS / stick:.0f}x | target >= 50x: {met} |")  # fmt: skip


if __name__ == "__main__":
    main()
