"""Make the mass-spring-damper example's log (docs/examples/mass-spring-damper/msd.csv).

A 2 kg mass on a 150 N/m spring with a 6 N·s/m damper, pushed by a force u that is a sum of
sines (0.1-3 Hz, random phases): m a + c v + k x = u, x positive in the direction u pushes.
The motion is integrated at 10 kHz (classical Runge-Kutta) and logged at 200 Hz for 25 s: x by
an encoder of 5 µm steps with 2 µm noise, u with 0.2 N noise. ``Fc`` adds Coulomb friction
(Fc tanh(v / 0.2 mm/s)); it is 0 here, see README.md beside this file. Deterministic (fixed
seed): ``python docs/examples/mass-spring-damper/make_data.py`` rewrites the same file.
"""

from pathlib import Path

import numpy as np

TRUTH = {"m": 2.0, "c": 6.0, "k": 150.0, "Fc": 0.0}  # kg, N·s/m, N/m, N
RATE_HZ, DURATION_S, SUBSTEPS, SEED = 200, 25.0, 50, 20261127


def simulate(seed: int = SEED) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    freqs = np.geomspace(0.1, 3.0, 24)
    amps = 3.0 * (freqs / 0.1) ** -0.3  # N; some of the force above the 1.4 Hz resonance
    phases = rng.uniform(0, 2 * np.pi, freqs.size)

    def force(t):
        return np.sin(2 * np.pi * np.multiply.outer(t, freqs) + phases) @ amps

    n = int(DURATION_S * RATE_HZ)
    dt = 1.0 / (RATE_HZ * SUBSTEPS)
    t = np.arange(n) / RATE_HZ
    m, c, k, fc = (TRUTH[p] for p in ("m", "c", "k", "Fc"))

    def accel(x, v, u):
        return (u - c * v - k * x - fc * np.tanh(v / 2e-4)) / m

    x = v = 0.0
    xs, us = np.empty(n), np.empty(n)
    for i in range(n):  # classical Runge-Kutta, the force evaluated where each stage is
        xs[i], us[i] = x, force(t[i])
        u = force(t[i] + dt * np.arange(2 * SUBSTEPS + 1) / 2)
        for j in range(SUBSTEPS):
            u0, uh, u1 = u[2 * j], u[2 * j + 1], u[2 * j + 2]
            a1 = accel(x, v, u0)
            a2 = accel(x + v * dt / 2, v + a1 * dt / 2, uh)
            a3 = accel(x + (v + a1 * dt / 2) * dt / 2, v + a2 * dt / 2, uh)
            a4 = accel(x + (v + a2 * dt / 2) * dt, v + a3 * dt, u1)
            x += dt * (v + (v + a1 * dt / 2) * 2 + (v + a2 * dt / 2) * 2 + (v + a3 * dt)) / 6
            v += dt * (a1 + 2 * a2 + 2 * a3 + a4) / 6
    x_logged = np.round((xs + rng.normal(0, 2e-6, n)) / 5e-6) * 5e-6  # 5 µm encoder steps
    u_logged = us + rng.normal(0, 0.2, n)
    return {"t_s": t, "x_mm": 1e3 * x_logged, "u_N": u_logged}


if __name__ == "__main__":
    columns = simulate()
    here = Path(__file__).resolve().parent
    table = np.column_stack(list(columns.values()))
    np.savetxt(here / "msd.csv", table, fmt=("%.3f", "%.3f", "%.4f"), delimiter=",",
               header=",".join(columns), comments="")  # fmt: skip
