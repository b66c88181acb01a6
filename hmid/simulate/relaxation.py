"""Thesis Ch. 2: a pre-stretched muscle with a 10 kg mass relaxes as its water escapes a valve.

Extension/retraction (thesis eqs. 2.3/2.4; elongation x > 0 downwards; water mass
m = rho A (L0 + x)):

    (m + m1) x'' = m1 g + P A - k x

The muscle's gauge pressure P follows from Bernoulli between muscle and valve exit (eq. 2.5) with
continuity A v_m = A_v v_v, both ends at the same height and the exit at atmosphere:

    P = rho/2 ((A / A_v)^2 - 1) x'^2        while water flows out (x' < 0)

Quasi-steady and inviscid, as in the thesis. The valve opens either at once or its area ramps at
1 % per ms. We integrate with SciPy's implicit Radau method (the ramp makes the equations stiff
near t = 0, where A_v -> 0) and stop at the first crossing of the equilibrium x_eq = m1 g / k.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.integrate import solve_ivp

from hmid.errors import SimulationError
from hmid.files import atomic_path, write_json


class RelaxationParams(BaseModel):
    """The Ch. 2 rig and muscle (thesis values)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    k: float = Field(5885.0, gt=0)  # N/m, latex core
    m1: float = Field(10.0, gt=0)  # kg, hanging mass
    L0: float = Field(0.165, gt=0)  # m, relaxed length
    A: float = Field(0.0014, gt=0)  # m^2, muscle cross-section
    A_v: float = Field(3.017e-4, gt=0)  # m^2, valve bore (20 mm)
    rho: float = Field(1000.0, gt=0)  # kg/m^3, water
    g: float = 9.80665
    P0: float = Field(5.0e4, gt=0)  # Pa, pre-stretch pressure (not in the thesis summary)
    open_rate: float = Field(10.0, gt=0)  # 1/s: 1 % of the valve area per ms


class RelaxationRun(BaseModel):
    """Data-set entry: the Ch. 2 experiment for the given valve cases (curves, figure, numbers)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    kind: Literal["relaxation"] = "relaxation"
    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", max_length=80)
    params: RelaxationParams = RelaxationParams()
    valves: tuple[Literal["instant", "ramp"], ...] = ("instant", "ramp")


class Relaxation(NamedTuple):
    """Result of one relaxation: curves from the valve opening to the equilibrium crossing."""

    valve: str
    t: np.ndarray
    x: np.ndarray  # elongation, m
    v: np.ndarray  # m/s (negative: retracting)
    a: np.ndarray  # m/s^2
    P: np.ndarray  # gauge pressure in the muscle, Pa
    t_eq: float  # s, first time x reaches m1 g / k
    x_eq: float


def relax(
    params: RelaxationParams | None = None,
    valve: Literal["instant", "ramp"] = "instant",
    *,
    t_max: float = 0.3,
    n_points: int = 3001,
) -> Relaxation:
    """Simulate the relaxation from the pre-stretched state until the equilibrium crossing."""
    p = params or RelaxationParams()
    x_eq = p.m1 * p.g / p.k
    x0 = (p.m1 * p.g + p.P0 * p.A) / p.k

    def valve_area(t):
        return p.A_v if valve == "instant" else p.A_v * min(1.0, p.open_rate * t)

    def pressure(t, v):
        area = valve_area(t)
        if v >= 0 or area <= 0:
            return 0.0 if area > 0 else p.P0  # a closed valve holds the initial pressure
        return 0.5 * p.rho * ((p.A / area) ** 2 - 1.0) * v * v

    def rhs(t, y):
        x, v = y
        mass = p.rho * p.A * (p.L0 + x) + p.m1
        return [v, (p.m1 * p.g + pressure(t, v) * p.A - p.k * x) / mass]

    def crossed(t, y):
        return y[0] - x_eq

    vars(crossed).update(terminal=True, direction=-1)  # attributes solve_ivp reads
    sol = solve_ivp(
        rhs, (0.0, t_max), [x0, 0.0], method="Radau", events=crossed, dense_output=True,
        rtol=1e-9, atol=[1e-12, 1e-10], max_step=1e-4,
    )  # fmt: skip
    if not sol.success or not sol.t_events[0].size:
        raise SimulationError(
            f"relaxation ({valve}) did not reach equilibrium within {t_max} s; check the params"
        )
    t_eq = float(sol.t_events[0][0])
    t = np.linspace(0.0, t_eq, n_points)
    x, v = sol.sol(t)
    a = np.array([rhs(ti, (xi, vi))[1] for ti, xi, vi in zip(t, x, v, strict=True)])
    P = np.array([pressure(ti, vi) for ti, vi in zip(t, v, strict=True)])
    return Relaxation(valve, t, x, v, a, P, t_eq, x_eq)


def write_relaxation(run: RelaxationRun, folder) -> list[Relaxation]:
    """``<name>.csv`` (curves of every valve case), ``<name>.png`` and ``<name>.truth.json``."""
    import pandas as pd

    results = [relax(run.params, valve) for valve in run.valves]
    curves = pd.concat(
        pd.DataFrame(
            {
                "valve": r.valve,
                "t_s": r.t,
                "x_m": r.x,
                "v_m_per_s": r.v,
                "a_m_per_s2": r.a,
                "P_Pa": r.P,
            }
        )
        for r in results
    )
    csv = folder / f"{run.name}.csv"
    with atomic_path(csv) as tmp:
        curves.to_csv(tmp, index=False, float_format="%.10g")
    figure = folder / f"{run.name}.png"
    with atomic_path(figure) as tmp:
        plot_relaxations(results, tmp)
    cases = {
        r.valve: {
            "t_equilibrium_ms": r.t_eq * 1e3,
            "peak_speed_m_s": float(abs(r.v).max()),
            "peak_pressure_after_opening_kPa": float(r.P[1:].max() / 1e3),
        }
        for r in results
    }
    write_json(
        folder / f"{run.name}.truth.json", {"params": run.params.model_dump(), "cases": cases}
    )
    return results


def plot_relaxations(results: list[Relaxation], path) -> None:
    """Elongation, velocity, acceleration and pressure curves of each valve case (one PNG)."""
    from matplotlib.figure import Figure  # object-oriented: no global backend switch

    fig = Figure(figsize=(7, 9))
    axes = fig.subplots(4, 1, sharex=True)
    rows = [("x", 1e3, "elongation [mm]"), ("v", 1.0, "velocity [m/s]"),
            ("a", 1.0, "acceleration [m/s²]"), ("P", 1e-3, "gauge pressure [kPa]")]  # fmt: skip
    for r in results:
        for ax, (name, scale, label) in zip(axes, rows, strict=True):
            ax.plot(r.t * 1e3, getattr(r, name) * scale, label=f"{r.valve} ({r.t_eq * 1e3:.1f} ms)")
            ax.set_ylabel(label)
    axes[0].axhline(results[0].x_eq * 1e3, color="grey", lw=0.8, ls="--")
    axes[0].legend(title="valve opening (time to equilibrium)")
    axes[-1].set_xlabel("time after the valve opens [ms]")
    fig.suptitle("Thesis Ch. 2: relaxation of a pre-stretched muscle with 10 kg")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
