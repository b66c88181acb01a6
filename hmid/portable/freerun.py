"""Free run of a loaded model: the position simulated from the measured inputs and the initial
state alone, as a controller uses the model (MATLAB's ``compare`` in simulation mode).

The rig's balance, with the model's terms in it, is an equation of motion: the explained
quantity (a force sensor read as ``motion``: mass a + offset; or known parts such as m a + m g;
or a measured input such as a drive force) equals the sum of the terms. Both sides are affine
in the acceleration a, which is solved for; the state is x, v and one internal state per memory
arm (dq/dt = -q/tau + v) and per first-order lag. Inputs (pressure, a drive force) are the
model's smoothed channels, interpolated linearly between samples.

**Stick-slip.** sign(v) is replaced by tanh(v / v0) (``v0``: the fit's low-speed cut-off
``fit.v_deadband``, 2 mm/s by default): a regularisation, not an event. Below v0 the block
creeps where the rig would stick; the error this costs is bounded by the stick band (about
2 Fc / k in position). An event-driven stick phase would need the static friction level, which
free falls do not measure.

Integration: diffrax's Tsit5 (5th order) with a PID step-size controller (rtol 1e-6), jit
compiled once per model and block length, the state saved at the log's samples. A run whose
state leaves finite numbers, or a box around the measured motion (x range widened by three
spans each side, |v| up to ten times the largest measured speed), is reported as diverged at
that time, with the state that left first.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache, partial
from typing import Any

import numpy as np

from hmid.balance.kinds import (
    ChannelTerm,
    ConstantTerm,
    CoulombTerm,
    Grid,
    LagTerm,
    MemoryTerm,
    SmoothCoulombTerm,
    TermSpec,
)


class NotSimulable(ValueError):
    """The model's balance is not an equation of motion this integrator runs (one line: why)."""


def _fixed(term: TermSpec, value: float | Grid) -> float:
    """A profiled parameter's value (the exported file holds it in place of the grid)."""
    if isinstance(value, Grid):
        raise NotSimulable(f"term {term.name}: a grid, not a value, for its profiled parameter")
    return float(value)


@dataclass(frozen=True)
class Equation:
    """The balance as an equation of motion: per term, how to evaluate it on the state.

    ``terms``: (kind, data, coefficient) with kind one of "const", "mono" (powers of x, v and
    inputs), "accel" (coefficient of a), "tanh" (tanh(v / scale)), "memory" (state index),
    "lag" (state index, input, T), "delay" (input, d), "friction" (free-fall law Fc + b |v|).
    ``inputs``: the channels read from the log. ``lhs``: the explained quantity the same way."""

    rhs: tuple
    lhs: tuple
    inputs: tuple[str, ...]
    n_memory: int
    lags: tuple[tuple[str, float], ...]
    v0: float


def equation(model, v0: float | None = None) -> Equation:
    """The equation of motion of ``model`` (:class:`~hmid.portable.Model`) on its rig."""
    rig = model.rig
    x = rig.position
    if x is None:
        raise NotSimulable("the rig declares no position: a free run does not apply")
    fit = model.document.get("fit") or {}
    v0 = float(v0 if v0 is not None else max(fit.get("v_deadband", 0.002), 1e-4))
    units = model.document["units"]
    inputs: list[str] = []
    memory: list[float] = []
    lags: list[tuple[str, float]] = []
    rhs: list[tuple[str, Any, float]] = []

    def channel(name: str) -> str:
        if name in (x, "v", "a"):
            return name
        if name not in inputs:
            inputs.append(name)
        return name

    def term_parts(term, coef: float) -> list:
        s = term.sign * coef
        if isinstance(term, ConstantTerm):
            return [("const", None, s)]
        if isinstance(term, ChannelTerm):
            powers = term.powers()
            if "a" in powers:
                if powers != {"a": 1}:
                    raise NotSimulable(f"term {term.name} ({term.channel}) is not linear in a")
                return [("accel", None, s)]
            return [("mono", tuple((channel(c), p) for c, p in powers.items()), s)]
        if isinstance(term, CoulombTerm):
            if term.channel != "v":
                raise NotSimulable(f"term {term.name}: sign of {term.channel}")
            return [("tanh", v0, s)]
        if isinstance(term, SmoothCoulombTerm):
            return [("tanh", float(term.scale), s)]
        if isinstance(term, MemoryTerm):
            if term.channel != x:
                raise NotSimulable(f"term {term.name}: a memory arm of {term.channel}")
            memory.append(_fixed(term, term.tau))
            return [("memory", (len(memory) - 1, _fixed(term, term.tau)), s)]
        if isinstance(term, LagTerm):
            if term.channel in (x, "v", "a"):
                raise NotSimulable(f"term {term.name}: a lag of the state {term.channel}")
            name = channel(term.channel)
            if term.filter == "delay":
                return [("delay", (name, _fixed(term, term.time)), s)]
            lags.append((name, _fixed(term, term.time)))
            return [("lag", len(lags) - 1, s)]
        raise NotSimulable(f"term {term.name} of kind {term.kind} has no free-run form")

    for term, coef in zip(model.terms, model.coef, strict=True):
        rhs += term_parts(term, float(coef))
    for term in rig.known:
        if getattr(term, "source", None) == "free_fall":
            law = model.document["known"]["free_fall_friction"]
            rhs.append(("friction", (float(law["Fc"]), float(law["b"]), v0), float(term.sign)))
        else:
            rhs += term_parts(term, rig.term_value(term, units))
    lhs: list[tuple[str, Any, float]]
    if rig.motion is not None:
        lhs = [("accel", None, float(rig.motion.mass)), ("const", None, float(rig.motion.offset))]
    else:
        lhs = []
        for value, part in zip(rig.part_values(units), rig.explained.parts, strict=True):
            powers = part.powers()
            if "a" in powers and powers != {"a": 1}:
                raise NotSimulable(f"the explained part {part.channel} is not linear in a")
            if powers == {"a": 1}:
                lhs.append(("accel", None, float(value)))
            elif not powers:
                lhs.append(("const", None, float(value)))
            else:
                lhs.append(("mono", tuple((channel(c), p) for c, p in powers.items()),
                            float(value)))  # fmt: skip
    if not any(kind == "accel" for kind, _, _ in (*rhs, *lhs)):
        raise NotSimulable(
            "the balance has no inertial term (no a, no motion): the rig imposes its position, "
            "so a free run does not apply"
        )
    return Equation(tuple(rhs), tuple(lhs), tuple(inputs), len(memory), tuple(lags), v0)


#: The kinds of a part of the balance, in the order of :class:`Program`'s flags.
KINDS = ("mono", "tanh", "memory", "lag", "delay", "friction", "accel")
#: Parts are padded to a multiple of this, powers to this degree: models of one rig then share
#: one compiled program (tracing diffrax costs seconds; running a model, milliseconds)
PARTS, DEGREE = 24, 4


@dataclass(frozen=True)
class Program:
    """An equation's parts as arrays, so that one compiled solver serves every model of the
    same shape (channels, memory arms, lags): ``side`` +1 on the model side, -1 on the explained
    side, 0 for padding; ``flags`` one row per kind of :data:`KINDS`; ``powers`` the exponents of
    x, v and the inputs; the rest each kind's data."""

    side: np.ndarray
    flags: np.ndarray
    powers: np.ndarray
    scale: np.ndarray
    memory: np.ndarray
    lag: np.ndarray
    delay_input: np.ndarray
    delay: np.ndarray
    friction: np.ndarray
    lag_input: np.ndarray  # the input each first-order lag follows

    @classmethod
    def of(cls, eq: Equation, position: str) -> Program:
        parts = [(+1, p) for p in eq.rhs] + [(-1, p) for p in eq.lhs]
        n = -(-len(parts) // PARTS) * PARTS
        channels = ["x", "v", *eq.inputs]
        out: dict[str, Any] = {
            "side": np.zeros(n), "flags": np.zeros((len(KINDS), n)),
            "powers": np.zeros((n, len(channels)), dtype=np.int32), "scale": np.ones(n),
            "memory": np.zeros(n, dtype=np.int32), "lag": np.zeros(n, dtype=np.int32),
            "delay_input": np.zeros(n, dtype=np.int32), "delay": np.zeros(n),
            "friction": np.tile([0.0, 0.0, 1.0], (n, 1)),
            "lag_input": np.array([eq.inputs.index(name) for name, _ in eq.lags], dtype=np.int32),
        }  # fmt: skip
        for i, (side, (kind, data, _)) in enumerate(parts):
            out["side"][i] = side
            if kind == "const":
                kind = "mono"
            out["flags"][KINDS.index(kind), i] = 1.0
            if kind == "mono" and data is not None:
                for name, power in _rename(data, position):
                    if power > DEGREE:
                        raise NotSimulable(f"a power {power} above {DEGREE} in the balance")
                    out["powers"][i, channels.index(name)] += power
            elif kind == "tanh":
                out["scale"][i] = data
            elif kind == "memory":
                out["memory"][i] = data[0]
            elif kind == "lag":
                out["lag"][i] = data
            elif kind == "delay":
                out["delay_input"][i], out["delay"][i] = eq.inputs.index(data[0]), data[1]
            elif kind == "friction":
                out["friction"][i] = data
        return cls(**out)

    def arrays(self) -> tuple[np.ndarray, ...]:
        return tuple(getattr(self, f.name) for f in fields(self))


def _solver(eq: Equation, position: str):
    """The compiled solvers for ``eq``'s shape, and its parts as arrays (:class:`Program`)."""
    program = Program.of(eq, position)
    delays = bool(program.flags[KINDS.index("delay")].any())
    run, batch = _compiled(len(program.side), len(eq.inputs), eq.n_memory, len(eq.lags),
                           delays)  # fmt: skip
    arrays = program.arrays()
    return partial(run, arrays), partial(batch, arrays)


@lru_cache(maxsize=32)
def _compiled(n_parts: int, n_inputs: int, m: int, n_lags: int, delays: bool):
    """Jitted functions (program, ts, count, y0, inputs, coef, taus, lag_times, noise) ->
    states at ts (``count``: how many of ts are samples, the rest padding), one run and one
    per row of draws, for every equation of this shape."""
    import diffrax
    import jax
    import jax.numpy as jnp

    def interpolator(ts, count, values):
        """Inputs at any time, linear between samples: the sample found from the mean step
        and corrected by up to two samples either way (a logger's jitter), not searched (a
        search per evaluation costs more than the whole step)."""
        step = (ts[count - 1] - ts[0]) / (count - 1)

        def at(time):
            k = jnp.clip(jnp.floor((time - ts[0]) / step).astype(jnp.int32), 0, count - 2)
            for _ in range(2):
                k = jnp.clip(k - (ts[k] > time) + (ts[k + 1] < time), 0, count - 2)
            w = (time - ts[k]) / (ts[k + 1] - ts[k])
            return values[:, k] * (1 - w) + values[:, k + 1] * w

        return at

    def parts(t, y, args):
        """Every part's regressor (its accel flag: the coefficient of a) and coefficient."""
        program, ts, count, table, coef, _, _ = args
        side, flags, powers, scale, memory, lag_of, delay_input, delay, friction, _ = program
        at = interpolator(ts, count, table)
        now = at(t)  # the inputs, then the disturbance
        x, v = y[0], y[1]
        z = jnp.concatenate([jnp.stack([x, v]), now[:n_inputs]])
        table_z = jnp.stack([z**k for k in range(DEGREE + 1)])  # (degree + 1, channels)
        mono = jnp.prod(table_z[powers, jnp.arange(z.shape[0])], axis=1)
        value = flags[0] * mono + flags[1] * jnp.tanh(v / scale)
        if m:
            value = value + flags[2] * y[2 + memory]
        if n_lags:
            value = value + flags[3] * y[2 + m + lag_of]
        if delays:
            late = jax.vmap(at)(t - delay)[jnp.arange(delay.shape[0]), delay_input]
            value = value + flags[4] * late
        fc, b, v0 = friction[:, 0], friction[:, 1], friction[:, 2]
        value = value + flags[5] * (fc + b * jnp.abs(v)) * jnp.tanh(v / v0)
        return value * (1 - flags[6]), flags[6], side * coef, now, side

    def field(t, y, args):
        value, accel, coef, now, _ = parts(t, y, args)
        taus, lag_times, lag_input = args[5], args[6], args[0][-1]
        alpha = jnp.sum(coef * value) + now[-1]  # the disturbance is a force on the model side
        a = -alpha / jnp.sum(coef * accel)
        v = y[1]
        dq = -y[2 : 2 + m] / taus + v
        lag = y[2 + m :]
        dlag = (now[lag_input] - lag) / lag_times if n_lags else lag
        return jnp.concatenate([jnp.stack([v, a]), dq, dlag])

    def explained(t, y, args):
        value, accel, coef, _, side = parts(t, y, args)
        a = field(t, y, args)[1]
        lhs = side < 0  # the explained side
        return -jnp.sum(jnp.where(lhs, coef * value, 0.0)) - jnp.sum(
            jnp.where(lhs, coef * accel, 0.0)) * a  # fmt: skip

    def solve(program, ts, count, y0, values, coef, taus, lag_times, noise, *, fixed: bool):
        table = jnp.concatenate([values, noise[None]])  # once, not at every evaluation
        args = (program, ts, count, table, coef, taus, lag_times)
        step = (ts[count - 1] - ts[0]) / (count - 1)
        control = diffrax.ConstantStepSize() if fixed else diffrax.PIDController(
            rtol=1e-6, atol=1e-9)  # fmt: skip
        solution = diffrax.diffeqsolve(
            diffrax.ODETerm(field), diffrax.Tsit5(), ts[0], ts[-1], step, y0, args=args,
            saveat=diffrax.SaveAt(ts=ts), stepsize_controller=control,
            max_steps=(2 if fixed else 64) * ts.shape[0], throw=False,
        )  # fmt: skip
        ys = solution.ys
        force = jax.vmap(lambda t, y: explained(t, y, args))(ts, ys)
        return ys, force, solution.result == diffrax.RESULTS.successful

    # The band's draws: one per row of the coefficients, the relaxation times and the
    # disturbance, each at steps of one sample (a disturbance sampled as noise has a kink at
    # every sample, where an error-controlled step would shrink to nothing)
    batch = jax.vmap(partial(solve, fixed=True), in_axes=(None, None, None, None, None, 0, 0,
                                                          None, 0))  # fmt: skip
    return jax.jit(partial(solve, fixed=False)), jax.jit(batch)


def _rename(data, position: str):
    """The position channel is called "x" inside the integrator."""
    if isinstance(data, tuple) and data and isinstance(data[0], tuple):
        return tuple(("x" if c == position else c, p) for c, p in data)
    return data


@dataclass(frozen=True)
class BlockRun:
    """One simulated block: measured and simulated position and explained quantity."""

    log: str
    t: np.ndarray
    x_measured: np.ndarray
    x_simulated: np.ndarray
    explained_measured: np.ndarray
    explained_simulated: np.ndarray | None  # None where the explained quantity is an input
    diverged_at: float | None
    reason: str = ""
    band: tuple[np.ndarray, np.ndarray] | None = None  # the position's band (lower, upper)


def blocks(signals, role: str = "validation") -> list[np.ndarray]:
    """Row spans to simulate: within each segment, from the first to the last row of ``role``,
    split where the role's rows stop for longer than a second (another block of the split)."""
    mask = signals.rows(role)
    t = signals["t"]
    out = []
    for rows in signals.segments():
        chosen = rows[mask[rows]]
        if len(chosen) < 10:
            continue
        breaks = np.flatnonzero(np.diff(t[chosen]) > 1.0) + 1
        for part in np.split(chosen, breaks):
            if len(part) >= 10:
                out.append(np.arange(part[0], part[-1] + 1))
    return out


@dataclass(frozen=True)
class FreeRun:
    """Every simulated block of one model, and what could not be simulated."""

    model: str
    runs: tuple[BlockRun, ...]
    skipped: str = ""  # why there is no free run (one line)
    level: float | None = None  # the band's nominal level, where the runs have one
    band: str = ""  # what the band is made of
    kept_scores: dict | None = None  # the scores of the whole runs, once they are thinned

    def thinned(self, points: int = 1500) -> FreeRun:
        """The same runs at most ``points`` samples each, for a figure, with the scores of the
        whole runs kept: what a run's cache and report hold (not a copy of the logs)."""
        blocks = []
        for r in self.runs:
            keep = slice(None, None, max(1, -(-len(r.t) // points)))
            band = None if r.band is None else (r.band[0][keep], r.band[1][keep])
            force = None if r.explained_simulated is None else r.explained_simulated[keep]
            blocks.append(replace(r, t=r.t[keep], x_measured=r.x_measured[keep],
                                  x_simulated=r.x_simulated[keep],
                                  explained_measured=r.explained_measured[keep],
                                  explained_simulated=force, band=band))  # fmt: skip
        return replace(self, runs=tuple(blocks), kept_scores=self.scores())

    def scores(self) -> dict:
        """Fit % of x (NRMSE fit, as MATLAB's compare), RMSE of x and of the explained
        quantity, over the blocks' samples before any divergence; divergences counted."""
        if self.kept_scores is not None:
            return self.kept_scores
        ok = [r for r in self.runs if r.diverged_at is None]
        out = {"free-run blocks": len(self.runs), "diverged": len(self.runs) - len(ok)}
        if not ok:
            return out | {"band coverage": np.nan, "fit % (x)": np.nan, "rmse x": np.nan,
                          "rmse explained": np.nan}  # fmt: skip
        err = np.concatenate([r.x_simulated - r.x_measured for r in ok])
        dev = np.concatenate([r.x_measured - r.x_measured.mean() for r in ok])
        forces = [r for r in ok if r.explained_simulated is not None]
        rmse_f = np.nan
        if forces:
            ferr = np.concatenate([r.explained_simulated - r.explained_measured for r in forces])
            rmse_f = float(np.sqrt(np.mean(ferr**2)))
        banded = [(r.x_measured, r.band) for r in ok if r.band is not None]
        coverage = np.nan
        if banded:
            inside = np.concatenate([(band[0] <= x) & (x <= band[1]) for x, band in banded])
            coverage = float(inside.mean())
        return out | {
            "band coverage": coverage,
            "fit % (x)": float(100 * (1 - np.linalg.norm(err) / np.linalg.norm(dev))),
            "rmse x": float(np.sqrt(np.mean(err**2))),
            "rmse explained": rmse_f,
        }


@dataclass(frozen=True)
class Trajectory:
    """A free run: position, velocity and the explained quantity (None where it is an input)
    at the times asked for; ``ok`` False if the solver stopped early (NaN after that)."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    explained: np.ndarray | None
    ok: bool


@dataclass(frozen=True)
class Simulator:
    """``model``'s equation of motion, compiled (:func:`simulator`)."""

    equation: Equation
    position: str
    run: Callable[..., Any] = field(repr=False)
    batch: Callable[..., Any] = field(repr=False)  # ``run`` over draws (vmapped)

    @property
    def n_memory(self) -> int:
        return self.equation.n_memory

    def coefficients(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        eq = self.equation
        return (
            np.array([c for _, _, c in eq.rhs], dtype=float),
            np.array([c for _, _, c in eq.lhs], dtype=float),
            np.array([d[1] for k, d, _ in eq.rhs if k == "memory"], dtype=float),
            np.array([T for _, T in eq.lags], dtype=float),
        )

    def _full(self, cr: np.ndarray, cl: np.ndarray) -> np.ndarray:
        """Both sides' coefficients in the program's part order, padded to its length (one
        shape for every model of the rig: one compiled program)."""
        out = np.zeros(-(-(len(cr) + len(cl)) // PARTS) * PARTS)
        out[: len(cr)], out[len(cr) : len(cr) + len(cl)] = cr, cl
        return out

    def integrate(self, t, inputs, x0: float, v0: float = 0.0, memory0=None, *,
                  coefficients=None, disturbance=None) -> Trajectory:  # fmt: skip
        """Run from (x0, v0) and the memory arms' states ``memory0`` (default: at rest) over
        the times ``t``, driven by ``inputs`` (name -> values at ``t``); ``coefficients``
        replaces :meth:`coefficients` (a posterior draw); ``disturbance`` is a force added to
        the balance's model side at ``t`` (default none)."""
        import jax
        import jax.numpy as jnp

        eq, n = self.equation, len(t)
        missing = [name for name in eq.inputs if name not in inputs]
        if missing:
            raise ValueError(f"the free run needs the inputs {missing} (at every time of t)")
        ts = _padded(np.asarray(t, dtype=float))
        values = np.stack([_padded(np.asarray(inputs[k], dtype=float)) for k in eq.inputs]) if (
            eq.inputs) else np.zeros((0, len(ts)))  # fmt: skip
        memory0 = np.zeros(eq.n_memory) if memory0 is None else np.asarray(memory0, dtype=float)
        lags0 = [values[eq.inputs.index(name), 0] for name, _ in eq.lags]
        y0 = np.concatenate([[x0, v0], memory0, lags0])
        cr, cl, taus, lag_times = coefficients or self.coefficients()
        noise = np.zeros(len(ts))
        if disturbance is not None:
            noise[:n] = disturbance
        with jax.enable_x64(True):
            arrays = (ts, np.int32(n), y0, values, self._full(cr, cl), taus, lag_times, noise)
            ys, force, ok = self.run(*(jnp.asarray(a) for a in arrays))
            ys, force = np.asarray(ys)[:n], np.asarray(force)[:n]
        output = any(k == "accel" for k, _, _ in eq.lhs)
        return Trajectory(np.asarray(t), ys[:, 0], ys[:, 1], force if output else None, bool(ok))

    def positions(self, t, inputs, x0, v0, memory0, draws, disturbances) -> np.ndarray:
        """The position (draws, len(t)) of one run per coefficient draw (each a tuple as
        :meth:`coefficients` gives) with its disturbance row, in one vectorised call."""
        import jax
        import jax.numpy as jnp

        eq, n = self.equation, len(t)
        ts = _padded(np.asarray(t, dtype=float))
        values = np.stack([_padded(np.asarray(inputs[k], dtype=float)) for k in eq.inputs]) if (
            eq.inputs) else np.zeros((0, len(ts)))  # fmt: skip
        lags0 = [values[eq.inputs.index(name), 0] for name, _ in eq.lags]
        y0 = np.concatenate([[x0, v0], np.asarray(memory0, dtype=float), lags0])
        coef = np.stack([self._full(d[0], d[1]) for d in draws])
        taus = np.stack([d[2] for d in draws])
        lag_times = draws[0][3]
        noise = np.zeros((len(draws), len(ts)))
        noise[:, :n] = disturbances
        with jax.enable_x64(True):
            arrays = (ts, np.int32(n), y0, values, coef, taus, lag_times, noise)
            ys, _, _ = self.batch(*(jnp.asarray(a) for a in arrays))
            return np.asarray(ys)[:, :n, 0]


def simulator(model, v0: float | None = None) -> Simulator:
    """The compiled free run of ``model``; :class:`NotSimulable` says why there is none."""
    eq = equation(model, v0)
    return Simulator(eq, model.rig.position, *_solver(eq, model.rig.position))


def coefficient_draws(model, sim: Simulator, n: int, seed: int) -> list[tuple] | None:
    """``n`` draws of the simulator's coefficients from the model's uncertainty: its posterior
    draws where it has them (the relaxation times drawn with the rest), else a normal with its
    coefficients' covariance; None where the file has neither."""
    cr, cl, taus, lags = sim.coefficients()
    n_terms = len(model.terms)
    signs = np.array([t.sign for t in model.terms], dtype=float)
    rng = np.random.default_rng(seed)
    posterior = model.posterior
    if posterior is not None:
        post = posterior.posterior
        names = [t.name for t in model.terms]
        arms = [t for t in model.terms if isinstance(t, MemoryTerm)]
        tau_names = ["tau"] if len(arms) == 1 else [f"tau_{i + 1}" for i in range(len(arms))]
        if not all(v in post for v in (*names, *tau_names)):
            return None
        flat = {v: np.asarray(post[v]).reshape(-1) for v in (*names, *tau_names)}
        pick = rng.choice(len(flat[names[0]]), size=n, replace=False)
        out = []
        for i in pick:
            draw = cr.copy()
            draw[:n_terms] = signs * np.array([flat[v][i] for v in names])
            out.append((draw, cl, np.array([flat[v][i] for v in tau_names]), lags))
        return out
    cov = model.covariance
    if cov is None:
        return None
    cov = (cov + cov.T) / 2  # symmetric to rounding; eigh clips the rounding below zero
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        coef = rng.multivariate_normal(model.coef, cov, size=n, method="eigh")
    out = []
    for row in coef:
        draw = cr.copy()
        draw[:n_terms] = signs * row
        out.append((draw, cl, taus, lags))
    return out


def disturbances(model, n: int, draws: int, rng) -> np.ndarray:
    """``draws`` realisations (rows of ``n`` samples) of the force the model leaves unexplained,
    as a disturbance of the free run: AR(1) with the training residual's RMS and integrated
    autocorrelation time tau (phi = (tau - 1) / (tau + 1)); zeros where the file has none."""
    residual = model.document.get("residual") or {}
    sigma, tau = residual.get("rmse"), residual.get("tau_int") or 1.0
    if not sigma:
        return np.zeros((draws, n))
    phi = (tau - 1.0) / (tau + 1.0)
    e = rng.standard_normal((draws, n)) * sigma * np.sqrt(1 - phi**2)
    from scipy.signal import lfilter

    start = rng.standard_normal(draws) * sigma
    return lfilter([1.0], [1.0, -phi], e, axis=1, zi=(phi * start)[:, None])[0]


def simulate_signals(
    model, signals, spans, *, v0: float | None = None, draws: int = 0, level: float = 0.9,
    seed: int = 0,
) -> FreeRun:  # fmt: skip
    """Free runs of ``model`` on ``signals`` over each span of rows (see :func:`blocks`), each
    from the measured state at its first row (the memory arms' states from the measured
    position before it); with ``draws``, a ``level`` band of the position from as many draws
    of the model's coefficients (:func:`coefficient_draws`)."""
    try:
        sim = simulator(model, v0)
    except NotSimulable as err:
        return FreeRun(model.name, (), str(err))
    sampled, band = None, ""
    if draws:
        sampled = coefficient_draws(model, sim, draws, seed)
        band = "posterior draws" if model.posterior is not None else "coefficient covariance"
        if sampled is None:
            sampled, band = [sim.coefficients()] * draws, "no coefficient uncertainty in the file"
        band += " + the training residual as a disturbance force"
    rng = np.random.default_rng([seed, 1])
    memory_rows = _memory_states(model, signals)
    position = model.rig.position
    out = []
    for rows in spans:
        inputs = {name: signals[name][rows] for name in sim.equation.inputs}
        first = rows[0]
        run = sim.integrate(signals["t"][rows], inputs, signals[position][first],
                            signals["v"][first], [m[first] for m in memory_rows])  # fmt: skip
        bounds = None
        if sampled:
            noise = disturbances(model, len(rows), len(sampled), rng)
            runs = sim.positions(signals["t"][rows], inputs, signals[position][first],
                                 signals["v"][first], [m[first] for m in memory_rows], sampled,
                                 noise)  # fmt: skip
            tail = (1 - level) / 2
            runs = np.where(np.isfinite(runs), runs, np.nan)  # a draw that diverged: left out
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN times: NaN bounds
                bounds = tuple(np.nanquantile(runs, [tail, 1 - tail], axis=0))
        out.append(_block(model.rig, signals, rows, run, bounds))
    return FreeRun(model.name, tuple(out), level=level if sampled else None, band=band)


#: Blocks are padded to a multiple of this many samples (the last one repeated, which the
#: integrator reaches without a step): one compiled program serves blocks of similar length.
PAD = 2048


def _padded(values: np.ndarray) -> np.ndarray:
    n = len(values)
    size = -(-n // PAD) * PAD
    return np.concatenate([values, np.full(size - n, values[-1])])


def _memory_states(model, signals) -> list[np.ndarray]:
    """Each memory arm's state g_tau(x) on every row, from the measured position (the block's
    initial state: the arm's response to the motion before it)."""
    from hmid.balance import Structure

    out = []
    for term in model.terms:
        if isinstance(term, MemoryTerm):
            column = Structure.of((term,)).columns(signals).values[:, 0]
            out.append(column / term.sign)
    return out


def _block(rig, signals, rows, run: Trajectory, band=None) -> BlockRun:
    x_meas = signals[rig.position][rows]
    v_meas = signals["v"][rows]
    span = np.ptp(x_meas) or 1e-3
    vmax = max(10 * np.max(np.abs(v_meas)), 1.0)
    x_out = ~np.isfinite(run.x) | (np.abs(run.x - x_meas.mean()) > 3.5 * span)
    v_out = ~np.isfinite(run.v) | (np.abs(run.v) > vmax)
    outside = x_out | v_out
    diverged_at, reason = None, ""
    if outside.any() or not run.ok:
        first = int(np.argmax(outside)) if outside.any() else len(rows) - 1
        diverged_at = float(run.t[first])
        state = "x" if x_out[first] else "v"
        reason = f"{state} left the measured range" if outside.any() else "the solver stopped"
    log = str(signals.frame["log"].iloc[rows[0]])
    return BlockRun(log, run.t, x_meas, run.x, signals["explained"][rows], run.explained,
                    diverged_at, reason, band)  # fmt: skip


def free_run(model, log, *, v0: float | None = None) -> FreeRun:
    """Free run of ``model`` over ``log`` (from its first usable row to its last) from the
    measured state there, driven by the log's inputs."""
    signals = model.signals(log)
    usable = np.flatnonzero(signals["usable"])
    spans = [np.arange(usable[0], usable[-1] + 1)] if len(usable) else []
    return simulate_signals(model, signals, spans, v0=v0)
