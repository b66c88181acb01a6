"""Free run of the discovered equation of motion on held-out data, driven by measured pressure.

    mass x'' = F_m(x, x', P) - friction(x') - offset     (Ch. 4: mass M + m1, offset m1 g)

``F_m`` is the discovered force map; friction is the identified law with ``sign(v)`` replaced by
the smooth stand-in ``tanh(v / v0)``: ``friction(v) = (Fc + b |v|) tanh(v / v0)``. An adaptive
solver (pysindy's ``simulate``: LSODA/RK45) stalls for minutes on a right-hand side with
``sign(v)``; the smooth law has a bounded slope ``Fc / v0`` and the integrator is a fixed-step
classical Runge-Kutta (RK4) with ``substeps`` steps per sample, the pressure interpolated linearly
between samples, so the cost is known in advance. With the smooth law the block creeps where the
rig would stick; the position error this costs is at most about the stick band 2 Fc / k (~0.2 mm
for the thesis's rig).

Each held-out block starts from the measured x and v at its first sample. A run that leaves
finite numbers, or a generous box around the log's measured motion (its x range widened by three
spans on each side; |v| up to ten times the largest measured speed, at least 1 m/s), is stopped
and reported as diverged *at* that time; it never raises. A wall-time bound (``max_seconds``,
shared by all blocks) stops the remaining work, reported as such.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.errors import ConfigError
from hmid.models.sindy._library import ForceMap

#: Samples between wall-time checks.
_CHECK_EVERY = 256


@dataclass(frozen=True)
class EquationOfMotion:
    """x'' = (s F(x, v, P) + s_f (Fc + b |v|) tanh(v / v0) - offset) / mass, SI units.

    From the rig's declared balance: the explained quantity is ``s F + s_f friction(v)`` (the
    model slot's force and the free-fall friction, with their declared signs) and, by its
    ``motion``, ``mass a + offset`` (thesis eqs. 4.1-4.2: mass = M + m1, offset = m1 g)."""

    force: ForceMap
    mass: float
    offset: float
    Fc: float
    b: float
    v0: float
    sign: int = 1  # the slot's sign in the balance
    friction_sign: int = -1  # +1: friction adds to the explained quantity, -1: subtracts

    @classmethod
    def from_rig(cls, force: ForceMap, rig, friction, v0: float) -> EquationOfMotion:
        """From a rig section (its ``motion``, slot and Coulomb term from the free falls) and the
        friction estimate whose law is Fc + b |v|."""
        if rig is None or rig.motion is None:
            raise ConfigError(
                "the equation of motion needs rig.motion (explained = mass a + offset)"
            )
        others = [t.name for t in rig.known if getattr(t, "source", None) != "free_fall"]
        if others or rig.fitted:
            names = others + [t.name for t in rig.fitted]
            raise ConfigError(f"the equation of motion cannot include the balance terms {names}")
        Fc, b = (0.0, 0.0) if not rig.from_free_fall else affine_friction(friction)
        sign = rig.from_free_fall[0].sign if rig.from_free_fall else -1
        return cls(force, float(rig.motion.mass), float(rig.motion.offset), Fc, b, float(v0),
                   int(rig.slot.sign), int(sign))  # fmt: skip

    def acceleration(self, x: float, v: float, P: float) -> float:
        friction = (self.Fc + self.b * abs(v)) * math.tanh(v / self.v0)
        drive = self.sign * self.force(x, v, P) + self.friction_sign * friction
        return (drive - self.offset) / self.mass

    def text(self) -> str:
        friction = f"{self.Fc:.4g} N"
        if self.b:
            friction = f"({friction} + {self.b:.4g} N·s/m·|v|)"
        force = "F_m(x, v, P)" if self.sign > 0 else "−F_m(x, v, P)"
        op = "+" if self.friction_sign > 0 else "−"
        return (
            f"ẍ [m/s²] = ({force} {op} {friction}·tanh(v / {self.v0:g} m/s) − {self.offset:.4g} N)"
            f" / {self.mass:.4g} kg"
        )


def affine_friction(friction) -> tuple[float, float]:
    """(Fc, b) of a friction estimate whose magnitude is Fc + b |v| for v > 0."""
    if friction is None:
        raise ConfigError("the equation of motion needs the identified friction")
    speeds = np.array([1e-9, 0.1, 1.0])
    magnitude = np.asarray(friction.friction(speeds), dtype=float)
    Fc = float(magnitude[0])
    b = float((magnitude[2] - magnitude[0]) / (speeds[2] - speeds[0]))
    if not np.isfinite([Fc, b]).all() or abs(Fc + b * 0.1 - magnitude[1]) > 1e-9 * (1 + abs(Fc)):
        raise ConfigError("the friction law is not Coulomb + viscous (Fc + b |v|)")
    return Fc, b


@dataclass(frozen=True)
class BlockRun:
    """One simulated held-out block; ``x_simulated`` is NaN after a failure."""

    log: str
    t: np.ndarray
    x_measured: np.ndarray
    x_simulated: np.ndarray
    status: str  # "ok", "diverged", "stopped" (wall time)
    failed_at: float | None  # s, log time of the failure
    reason: str

    @property
    def rmse(self) -> float:
        """RMS of x error (m) over the samples simulated before any failure."""
        done = np.isfinite(self.x_simulated)
        if not done.any():
            return float("nan")
        return float(np.sqrt(np.mean((self.x_simulated[done] - self.x_measured[done]) ** 2)))


@dataclass(frozen=True)
class FreeRunResult:
    """Every held-out block's free run, and the settings it ran with."""

    blocks: tuple[BlockRun, ...]
    substeps: int
    v0: float
    max_seconds: float
    wall_seconds: float

    @property
    def diverged(self) -> tuple[BlockRun, ...]:
        return tuple(b for b in self.blocks if b.status == "diverged")

    @property
    def rmse(self) -> float:
        """Pooled x RMSE (m) over the blocks that ran to the end; NaN if none did."""
        ok = [b for b in self.blocks if b.status == "ok"]
        if not ok:
            return float("nan")
        err = np.concatenate([b.x_simulated - b.x_measured for b in ok])
        return float(np.sqrt(np.mean(err**2)))

    def table(self) -> pd.DataFrame:
        return pd.DataFrame(
            {
                "log": [b.log for b in self.blocks],
                "t start [s]": [float(b.t[0]) for b in self.blocks],
                "t end [s]": [float(b.t[-1]) for b in self.blocks],
                "x rmse [mm]": [1e3 * b.rmse for b in self.blocks],
                "x std [mm]": [1e3 * float(np.std(b.x_measured)) for b in self.blocks],
                "status": [b.status for b in self.blocks],
                "failed at [s]": [b.failed_at for b in self.blocks],
            }
        )

    def summary(self) -> dict:
        return {
            "free_run_blocks": len(self.blocks),
            "free_run_diverged": len(self.diverged),
            "free_run_stopped": sum(b.status == "stopped" for b in self.blocks),
            "free_run_rmse_x_m": self.rmse,
            "free_run_substeps": self.substeps,
            "free_run_v0": self.v0,
        }  # wall time stays in the report text: metrics must repeat exactly

    def text(self) -> str:
        if not self.blocks:
            return "Free run: no held-out block to simulate."
        lines = [
            f"Free run of the equation of motion on {len(self.blocks)} held-out block(s), driven "
            f"by the measured pressure, from the measured x, v at each block's start (fixed-step "
            f"RK4, {self.substeps} steps per sample, friction sign(v) → tanh(v / {self.v0:g} m/s),"
            f" {self.wall_seconds:.2f} s of {self.max_seconds:g} s allowed): "
            + (
                f"x RMSE {1e3 * self.rmse:.3g} mm over the blocks that ran to the end."
                if math.isfinite(self.rmse)
                else "no block ran to the end."
            )
        ]
        for b in self.blocks:
            if b.status != "ok":
                lines.append(
                    f"- **{b.status}**: {b.log} block {b.t[0]:.3f}–{b.t[-1]:.3f} s "
                    f"at t = {b.failed_at:.4f} s ({b.reason})"
                )
        return "\n".join(lines)


@dataclass(frozen=True)
class _Run:
    x: np.ndarray
    v: np.ndarray | None  # None for a block never started
    status: str
    failed_at: float | None
    reason: str


def simulate(
    eom: EquationOfMotion,
    t: np.ndarray,
    P: np.ndarray,
    x0: float,
    v_start: float,
    *,
    substeps: int = 2,
    x_bounds: tuple[float, float] = (-math.inf, math.inf),
    v_limit: float = math.inf,
    deadline: float | None = None,
) -> _Run:
    """Fixed-step RK4 of ``eom`` over the sample times ``t`` with pressure ``P`` (linear between
    samples); stops at the first sample outside the bounds (or non-finite) or past ``deadline``
    (a ``time.perf_counter()`` value). Plain Python floats: ~25 µs per step."""
    n = len(t)
    xs, vs = np.full(n, np.nan), np.full(n, np.nan)
    x, v = float(x0), float(v_start)
    xs[0], vs[0] = x, v
    acc = eom.acceleration
    times, pressures = np.asarray(t, dtype=float).tolist(), np.asarray(P, dtype=float).tolist()
    lo, hi = x_bounds
    with np.errstate(over="ignore", invalid="ignore"):  # a diverging run is detected below
        return _integrate(acc, times, pressures, xs, vs, x, v, substeps, lo, hi, v_limit, deadline)


def _integrate(acc, times, pressures, xs, vs, x, v, substeps, lo, hi, v_limit, deadline) -> _Run:
    n = len(times)
    for k in range(n - 1):
        try:
            h = (times[k + 1] - times[k]) / substeps
            dP = (pressures[k + 1] - pressures[k]) / substeps
            for s in range(substeps):
                Pa = pressures[k] + s * dP
                Pm, Pb = Pa + 0.5 * dP, Pa + dP
                a1 = acc(x, v, Pa)
                v2 = v + 0.5 * h * a1
                a2 = acc(x + 0.5 * h * v, v2, Pm)
                v3 = v + 0.5 * h * a2
                a3 = acc(x + 0.5 * h * v2, v3, Pm)
                v4 = v + h * a3
                a4 = acc(x + h * v3, v4, Pb)
                x += h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
                v += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        except ArithmeticError as err:  # e.g. OverflowError from a user-supplied force map
            return _Run(xs, vs, "diverged", times[k + 1], f"{type(err).__name__}: {err}")
        if not (lo <= x <= hi and abs(v) <= v_limit):  # NaN fails every comparison
            what = "non-finite state" if not (math.isfinite(x) and math.isfinite(v)) else (
                f"x = {x:.3g} m outside [{lo:.3g}, {hi:.3g}] m"
                if not lo <= x <= hi
                else f"|v| = {abs(v):.3g} m/s above {v_limit:.3g} m/s"
            )  # fmt: skip
            return _Run(xs, vs, "diverged", times[k + 1], what)
        xs[k + 1], vs[k + 1] = x, v
        if deadline is not None and k % _CHECK_EVERY == 0 and time.perf_counter() > deadline:
            return _Run(xs, vs, "stopped", times[k + 1], "wall-time limit reached")
    return _Run(xs, vs, "ok", None, "")


def held_out_blocks(sequences: Mapping[str, pd.DataFrame]) -> list[tuple[str, pd.DataFrame]]:
    """Contiguous held-out stretches of each log: from the first to the last validation row of
    each run of rows that are not training rows (stuck rows inside are simulated too)."""
    out = []
    for name, frame in sequences.items():
        train = frame["train"].to_numpy(dtype=bool)
        validation = frame["validation"].to_numpy(dtype=bool)
        run_id = np.cumsum(np.r_[True, train[1:] != train[:-1]])
        for r in np.unique(run_id[~train]):
            rows = np.flatnonzero((run_id == r) & validation)
            if len(rows) >= 2:
                out.append((str(name), frame.iloc[rows[0] : rows[-1] + 1].reset_index(drop=True)))
    return out


def free_run(
    eom: EquationOfMotion,
    sequences: Mapping[str, pd.DataFrame],
    *,
    substeps: int = 2,
    max_seconds: float = 30.0,
    velocity: Mapping[str, np.ndarray] | None = None,
) -> FreeRunResult:
    """Simulate every held-out block of ``sequences`` (columns t, x, v, P, train, validation).

    ``velocity`` optionally replaces each log's ``v`` column (initial speeds) by another estimate.
    """
    start = time.perf_counter()
    deadline = start + max_seconds
    runs = []
    for name, block in held_out_blocks(sequences):
        full = sequences[name]
        x_all = full["x"].to_numpy()
        v_all = full["v"].to_numpy() if velocity is None else np.asarray(velocity[name])
        span = max(float(np.ptp(x_all)), 1e-3)
        bounds = (float(x_all.min()) - 3 * span, float(x_all.max()) + 3 * span)
        v_limit = max(10 * float(np.max(np.abs(v_all))), 1.0)
        t, x, P = (block[c].to_numpy(dtype=float) for c in ("t", "x", "P"))
        first = int(np.searchsorted(full["t"].to_numpy(), t[0]))
        if time.perf_counter() > deadline:
            run = _Run(np.full(len(t), np.nan), None, "stopped", float(t[0]), "wall-time limit")
        else:
            run = simulate(
                eom, t, P, x[0], float(v_all[first]), substeps=substeps, x_bounds=bounds,
                v_limit=v_limit, deadline=deadline,
            )  # fmt: skip
        runs.append(BlockRun(name, t, x, run.x, run.status, run.failed_at, run.reason))
    return FreeRunResult(tuple(runs), substeps, eom.v0, max_seconds, time.perf_counter() - start)
