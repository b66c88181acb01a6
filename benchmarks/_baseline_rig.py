"""Baseline for the simulator benchmark: the same stick-slip rig step as a plain Python loop.

This is what a researcher would write first (no JAX); it follows the equations of
hmid.simulate.rigs.hydro_muscle (slew-limited valve, SLS muscle, Coulomb stick-slip, semi-implicit
Euler) without effects.
"""

import math

import numpy as np

from hmid.simulate.params import RigParams


def integrate_python(rig: RigParams, P_cmd: np.ndarray, rate: float, x0: float, substeps: int):
    m, f, vlv = rig.muscle, rig.friction, rig.valve
    mass, Fc, dt = rig.M + rig.m1, f.coulomb, 1.0 / (rate * substeps)
    decay = math.exp(-dt / m.tau)
    x, v, q, P, stuck = x0, 0.0, 0.0, float(P_cmd[0]), True
    out = np.empty(len(P_cmd))
    for k, Pc in enumerate(P_cmd):
        for _ in range(substeps):
            P += min(max((Pc - P) / vlv.tau, -vlv.slew), vlv.slew) * dt
            F_app = m.A_eff * P + m.F0 - (m.k1 * x + m.k3 * x**3 + q) - rig.m1 * rig.g
            if stuck:
                if abs(F_app) <= Fc:
                    a = 0.0
                else:
                    a, stuck = (F_app - math.copysign(Fc, F_app)) / mass, False
            else:
                a = (F_app - math.copysign(Fc, v)) / mass
            v_new = v + a * dt
            if not stuck and v_new * v < 0:
                v_new, stuck = 0.0, True
            v = v_new
            x += v * dt
            q = q * decay + m.k2 * m.tau * (1 - decay) * v
        out[k] = x
    return out
