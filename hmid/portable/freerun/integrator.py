"""The compiled integrators: one error-controlled run, and fixed-step runs over many draws.

A model's free run is Tsit5 (5th order, diffrax's tableau, its stages unrolled: :func:`tsit5`)
with diffrax's PID step-size controller (rtol 1e-6) over the block, its dense output read at
the log's samples. The band's draws each carry a disturbance force sampled at the samples,
which has a kink at every sample where an error-controlled step would shrink to nothing: they
take diffrax's Tsit5 steps of exactly one sample (``solver.step`` in a loop), vectorised over
the draws (there, unrolling the stages saves nothing: 64 draws' steps cost their arithmetic).

Both are compiled once per :class:`~hmid.portable.freerun.program.Shape` (``lru_cache``) and
are pure XLA programs, without host callbacks (no ``SaveAt(ts=...)``, whose checks are
callbacks; no traced ``dt0``): JAX's persistent compilation cache keeps them, so a second run
loads them instead of compiling (:mod:`hmid.pipeline.compilation`). Blocks are padded to a
multiple of :data:`PAD` samples (the last one repeated); the loops stop at the real last
sample, so padding costs memory, never steps, and one program serves a run's every block.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from hmid.portable.freerun.equation import Equation, equation, free_run_v0
from hmid.portable.freerun.program import Program, Shape, vector_field
from hmid.portable.freerun.stored import stored

#: Blocks are padded to a multiple of this many samples.
PAD = 4096
#: The controller's tolerances, and its most steps per sample (then the run stops, not ok):
#: each step's state is kept, so this sizes the program's arrays (a log takes about one step
#: per two to six samples).
RTOL, ATOL, STEPS_PER_SAMPLE = 1e-6, 1e-9, 2
#: The longest step, in samples: the states between steps are interpolated (:func:`_hermite`),
#: as accurate as the steps over eight samples. Sixteen took the linear stage's bench log from
#: 8,233 steps to ~6,200 (-27 % of its time) but the shipped linear stage's free run (v0 =
#: 0.1 mm/s) then missed a tight solution's RMSE (rtol 1e-10, one-sample steps) by 3.4 %, where
#: eight misses it by 0.7 % (and the cubic reading of main by 1.6 %)
MAX_STEP = 8.0


@lru_cache(maxsize=1)
def tsit5():
    """Tsit5 as a diffrax solver whose step is its six stages written out, from diffrax's own
    Butcher tableau (``diffrax.Tsit5.tableau``). diffrax's generic Runge-Kutta step runs its
    stages in a loop (one code path for explicit, implicit and IMEX tableaus), and on XLA:CPU a
    step of these 2-8 wide states costs the kernels it launches, not their arithmetic: written
    out, a step launches about half as many (the linear stage's 40 s log 43 -> 31 ms of CPU;
    the steps agree with ``diffrax.Tsit5`` to rounding). Implicit tableaus (Kvaerno3/4/5) were
    measured on the linear stage's friction, stiff near v = 0: 12,000-31,000 steps at 40-85 us
    each, 9-20x slower than Tsit5 (``benchmarks/README.md``)."""
    import diffrax
    import jax

    class UnrolledTsit5(diffrax.AbstractAdaptiveSolver):
        # class attributes, not fields (unannotated): a solver with no fields is hashable
        tableau = diffrax.Tsit5.tableau
        term_structure = diffrax.AbstractTerm
        interpolation_cls = diffrax.LocalLinearInterpolation

        def order(self, terms):
            return 5

        def error_order(self, terms):
            return 5

        def init(self, terms, t0, t1, y0, args):
            return terms.vf(t0, y0, args)  # first same as last: a step's f(t0, y0)

        def func(self, terms, t0, y0, args):
            return terms.vf(t0, y0, args)

        def step(self, terms, t0, t1, y0, args, f0, made_jump):
            tab = self.tableau
            if made_jump is not False:  # the previous step's last stage is not f(t0, y0)
                f0 = jax.lax.cond(made_jump, lambda: terms.vf(t0, y0, args), lambda: f0)
            h = t1 - t0
            ks = [f0]
            for c, row in zip(tab.c, tab.a_lower, strict=True):
                y = y0 + h * sum(float(a) * k for a, k in zip(row, ks, strict=True) if a != 0)
                ks.append(terms.vf(t0 + float(c) * h, y, args))
            # the last stage is at (t1, y1) (first same as last)
            error = h * sum(float(b) * k for b, k in zip(tab.b_error, ks, strict=True) if b != 0)
            return y, error, {"y0": y0, "y1": y}, ks[-1], diffrax.RESULTS.successful

    assert UnrolledTsit5.tableau.fsal and UnrolledTsit5.tableau.ssal
    return UnrolledTsit5()


def padded_size(n: int) -> int:
    """``n`` samples padded: the next multiple of :data:`PAD`."""
    return -(-n // PAD) * PAD


def padded(values: np.ndarray, size: int | None = None) -> np.ndarray:
    """``values`` padded to ``size`` (default: :func:`padded_size`) with the last."""
    n = len(values)
    return np.concatenate([values, np.full((size or padded_size(n)) - n, values[-1])])


@lru_cache(maxsize=16)
def compiled(shape: Shape):
    """``(run, explain, draws)`` for programs of ``shape``, jitted (and kept on disk:
    :mod:`.stored`). ``run(program, dts, count, y0, table, noise, coef, taus, lag_times) ->
    (states, ok)`` at every sample (``count``: how many of the padded samples are real; NaN
    after a solver that stopped); ``explain`` the same arguments and the states -> the explained
    quantity they imply (a program of its own: a model whose explained side is an input never
    pays for it); ``draws`` the arguments of ``run`` with a row of ``noise``, ``coef`` and
    ``taus`` per draw, and a stride, -> the
    position (draws, samples) at every stride-th sample.

    The functions are built (and diffrax imported) only when a program is traced: a process
    that reads every program back from disk never imports diffrax (0.7 s of the demo's free-run
    stage)."""
    functions = lru_cache(maxsize=1)(lambda: _functions(shape))

    def late(i: int, name: str) -> Callable[..., Any]:
        def fn(*args):
            return functions()[i](*args)

        fn.__name__ = fn.__qualname__ = name  # the traced program's name, as before
        return stored(fn, name, shape)

    return late(0, "run"), late(1, "explain"), late(2, "draws")


def _functions(shape: Shape):
    """The pure functions behind :func:`compiled`'s programs, to trace."""
    import diffrax
    import jax
    import jax.numpy as jnp

    prepare, rhs, explained = vector_field(shape)
    term = diffrax.ODETerm(rhs)
    solver, fixed = tsit5(), diffrax.Tsit5()  # the draws' steps, vectorised, cost arithmetic

    def run(program, dts, count, y0, table, noise, coef, taus, lag_times):
        args = (prepare(program, dts, count, table, coef, taus, lag_times), table, noise)
        end = (count - 1).astype(dts.dtype)

        # each accepted step's state, slope and the position's second derivative (d/ds of
        # v dt: the slope of v times dt) for the Hermite interpolation below, evaluated in the
        # loop: two kernels of a step's 36; afterwards for every slot, ~15 % slower; carried by
        # the solver's dense info, no faster (benchmarks/README.md, 2026-11-27 19:30)
        def saved_fn(s, y, a):
            slope = rhs(s, y, a)
            dt = a[0]["dts"][jnp.clip(jnp.floor(s).astype(jnp.int32), 0, count - 2)]
            return jnp.concatenate([y, slope, slope[1:2] * dt])

        saved = diffrax.SaveAt(t0=True, steps=True, fn=saved_fn)
        solution = diffrax.diffeqsolve(
            term, solver, 0.0, end, None, y0, args=args, saveat=saved,
            stepsize_controller=diffrax.PIDController(rtol=RTOL, atol=ATOL, dtmax=MAX_STEP),
            adjoint=diffrax.ForwardMode(), max_steps=STEPS_PER_SAMPLE * dts.shape[0],
            throw=False,
        )  # fmt: skip
        grid = jnp.minimum(jnp.arange(dts.shape[0]), count - 1).astype(dts.dtype)
        n = y0.shape[0]
        ys = _hermite(solution.ts, solution.ys[:, :n], solution.ys[:, n : 2 * n], grid,
                      solution.ys[:, 2 * n])  # fmt: skip
        return ys, solution.result == diffrax.RESULTS.successful

    def explain(program, dts, count, y0, table, noise, coef, taus, lag_times, ys):
        args = (prepare(program, dts, count, table, coef, taus, lag_times), table, noise)
        grid = jnp.minimum(jnp.arange(dts.shape[0]), count - 1).astype(dts.dtype)
        return jax.vmap(lambda s, y: explained(s, y, args))(grid, ys)

    def one_draw(program, dts, count, y0, table, noise, coef, taus, lag_times, stride):
        args = (prepare(program, dts, count, table, coef, taus, lag_times), table, noise)
        state = fixed.init(term, 0.0, 1.0, y0, args)
        end = (count - 1).astype(dts.dtype)

        def step(k, carry):
            y, state, xs = carry
            s = (k * stride).astype(dts.dtype)
            y, _, _, state, _ = fixed.step(term, s, jnp.minimum(s + stride, end), y, args,
                                           state, made_jump=False)  # fmt: skip
            return y, state, xs.at[k + 1].set(y[0])

        xs = jnp.full(dts.shape[0], jnp.nan).at[0].set(y0[0])
        steps = (count - 1 + stride - 1) // stride
        return jax.lax.fori_loop(0, steps, step, (y0, state, xs))[2]

    draws = jax.vmap(one_draw, in_axes=(None, None, None, None, None, 0, 0, 0, None, None))
    return run, explain, draws


def _hermite(ts, ys, slopes, grid, curvature):
    """The states at ``grid`` from the accepted steps' values and slopes: cubic Hermite between
    steps (4th-order local error, as Tsit5's own dense output), the position quintic with its
    second derivative ``curvature`` too (6th-order; the velocity's would cost a vector field
    evaluation per step). On the bench's SLS log the quintic took the miss of a tight solution
    from 3.8e-6 to 7.7e-7 of the range. One binary search for every sample (``SaveAt(ts=...)``
    checks its times with a host callback, and evaluating diffrax's dense output sample by
    sample costs more than the solve; a search by sorting the steps and the samples together
    took 16 ms of a 40 s log's 76 ms, the binary search 1 ms). Steps never taken are inf:
    samples past the last step are NaN."""
    import jax.numpy as jnp

    ts = jnp.where(jnp.isfinite(ts), ts, jnp.inf)
    slopes = jnp.nan_to_num(slopes)
    k = jnp.clip(jnp.searchsorted(ts, grid, side="right", method="scan") - 1, 0,
                 ts.shape[0] - 2)  # fmt: skip
    t0, t1 = ts[k], ts[k + 1]
    h = t1 - t0
    w = ((grid - t0) / h)[:, None]
    h = h[:, None]
    y0, y1, m0, m1 = ys[k], ys[k + 1], slopes[k], slopes[k + 1]
    out = ((2 * w**3 - 3 * w**2 + 1) * y0 + (w**3 - 2 * w**2 + w) * h * m0
           + (-2 * w**3 + 3 * w**2) * y1 + (w**3 - w**2) * h * m1)  # fmt: skip
    curvature = jnp.nan_to_num(curvature)
    c0, c1, w, h = curvature[k], curvature[k + 1], w[:, 0], h[:, 0]
    position = ((1 - 10 * w**3 + 15 * w**4 - 6 * w**5) * y0[:, 0]
                + (w - 6 * w**3 + 8 * w**4 - 3 * w**5) * h * m0[:, 0]
                + (w**2 - 3 * w**3 + 3 * w**4 - w**5) / 2 * h**2 * c0
                + (w**3 - 2 * w**4 + w**5) / 2 * h**2 * c1
                + (-4 * w**3 + 7 * w**4 - 3 * w**5) * h * m1[:, 0]
                + (10 * w**3 - 15 * w**4 + 6 * w**5) * y1[:, 0])  # fmt: skip
    out = out.at[:, 0].set(position)
    exact = (grid == t0)[:, None]  # a sample on a step (the last one, a one-step block)
    out = jnp.where(exact, y0, out)
    return jnp.where(jnp.isfinite(t1)[:, None] | exact, out, jnp.nan)


@dataclass(frozen=True)
class FreeTrajectory:
    """A free run: position, velocity and the explained quantity (None where it is an input)
    at the times asked for; ``ok`` False if the solver stopped early (NaN after that)."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    explained: np.ndarray | None
    ok: bool


#: One draw's coefficients: the model side's and the explained side's (in the equation's part
#: order), the memory arms' relaxation times, the lags' time constants.
Coefficients = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Simulator:
    """``model``'s equation of motion, compiled (:func:`simulator`)."""

    equation: Equation
    position: str
    shape: Shape
    program: tuple[np.ndarray, ...] = field(repr=False)
    run: Callable[..., Any] = field(repr=False)
    explain: Callable[..., Any] = field(repr=False)  # the explained quantity of ``run``'s states
    draws: Callable[..., Any] = field(repr=False)  # ``run`` over draws, at fixed steps

    @property
    def n_memory(self) -> int:
        return self.equation.n_memory

    def coefficients(self) -> Coefficients:
        eq = self.equation
        return (
            np.array([c for _, _, c in eq.rhs], dtype=float),
            np.array([c for _, _, c in eq.lhs], dtype=float),
            np.array([d[1] for k, d, _ in eq.rhs if k == "memory"], dtype=float),
            np.array([T for _, T in eq.lags], dtype=float),
        )

    def _padded(self, c: Coefficients) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Both sides' coefficients in the program's part order, and the time constants,
        padded to the program's shape (padded states relax in 1 s and are read by no part)."""
        cr, cl, taus, lags = c
        coef = np.zeros(self.shape.parts)
        coef[: len(cr)], coef[len(cr) : len(cr) + len(cl)] = cr, cl
        return (coef, np.concatenate([taus, np.ones(self.shape.memory - len(taus))]),
                np.concatenate([lags, np.ones(self.shape.lags - len(lags))]))  # fmt: skip

    def _block(self, t, inputs, x0, v0, memory0, size=None):
        """The arguments a compiled program reads for one block (padded to ``size``)."""
        eq, shape = self.equation, self.shape
        missing = [name for name in eq.inputs if name not in inputs]
        if missing:
            raise ValueError(f"the free run needs the inputs {missing} (at every time of t)")
        t = np.asarray(t, dtype=float)
        if len(t) < 2:
            raise ValueError("the free run needs at least two times")
        dts = padded(np.diff(t), max(size or 0, padded_size(len(t))))
        values = np.zeros((shape.inputs, len(dts)))
        for i, name in enumerate(eq.inputs):
            values[i] = padded(np.asarray(inputs[name], dtype=float), len(dts))
        memory = np.zeros(shape.memory)
        if memory0 is not None:
            memory[: eq.n_memory] = np.asarray(memory0, dtype=float)
        lags = np.zeros(shape.lags)
        lags[: len(eq.lags)] = [values[eq.inputs.index(name), 0] for name, _ in eq.lags]
        y0 = np.concatenate([[x0, v0], memory, lags])
        return dts, np.int32(len(t)), y0, values

    def integrate(self, t, inputs, x0: float, v0: float = 0.0, memory0=None, *,
                  coefficients: Coefficients | None = None, disturbance=None,
                  size: int | None = None) -> FreeTrajectory:  # fmt: skip
        """Run from (x0, v0) and the memory arms' states ``memory0`` (default: at rest) over
        the times ``t``, driven by ``inputs`` (name -> values at ``t``); ``coefficients``
        replaces :meth:`coefficients` (a posterior draw); ``disturbance`` is a force added to
        the balance's model side at ``t`` (default none); ``size``: the samples to pad to
        (blocks of one size share one compiled program)."""
        import jax

        dts, count, y0, values = self._block(t, inputs, x0, v0, memory0, size)
        n = int(count)
        noise = np.zeros(len(dts))
        if disturbance is not None:
            noise[:n] = disturbance
        coef, taus, lag_times = self._padded(coefficients or self.coefficients())
        output = any(k == "accel" for k, _, _ in self.equation.lhs)
        with jax.enable_x64(True):
            # numpy arguments straight to the jitted programs: their own transfer is a fraction
            # of ``jnp.asarray``'s dispatch per array (tens of µs each, 4,000 a demo)
            arrays = (self.program, dts, count, y0, values, noise, coef, taus, lag_times)
            states, ok = self.run(*arrays)
            force = np.asarray(self.explain(*arrays, states))[:n] if output else None
            ys = np.asarray(states)[:n]
        return FreeTrajectory(np.asarray(t), ys[:, 0], ys[:, 1], force, bool(ok))

    def positions(self, t, inputs, x0, v0, memory0, draws: list[Coefficients],
                  disturbances: np.ndarray, stride: int = 1,
                  size: int | None = None) -> np.ndarray:  # fmt: skip
        """The position (draws, len(t)) of one run per coefficient draw with its disturbance
        row, in one vectorised call, at fixed steps of ``stride`` samples (the position
        linear between them)."""
        import jax

        dts, count, y0, values = self._block(t, inputs, x0, v0, memory0, size)
        n = int(count)
        rows = [self._padded(d) for d in draws]
        coef, taus = np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows])
        noise = np.zeros((len(draws), len(dts)))
        noise[:, :n] = disturbances
        with jax.enable_x64(True):
            xs = np.asarray(self.draws(self.program, dts, count, y0, values, noise, coef, taus,
                                       rows[0][2], np.int32(stride)))  # fmt: skip
        if stride == 1:
            return xs[:, :n]
        # linear between the steps, every row at once (the steps lie every stride samples)
        k = np.arange(n) // stride
        w = (np.arange(n) - k * stride) / np.where(k * stride + stride <= n - 1, stride,
                                                  np.maximum(n - 1 - k * stride, 1))  # fmt: skip
        nxt = np.minimum(k + 1, xs.shape[1] - 1)
        # a sample on a step is that step's position (the slot after the last step is NaN); a
        # diverged draw's inf times a weight of 0 is NaN, as a diverged sample is read anyway
        with np.errstate(invalid="ignore"):
            return np.where(w == 0, xs[:, k], xs[:, k] * (1 - w) + xs[:, nxt] * w)


def simulator(model, v0: float | None = None) -> Simulator:
    """The compiled free run of ``model`` (friction regularised at ``v0``, by default the least
    a sample's step integrates stably: :func:`~.equation.free_run_v0`); :class:`NotSimulable`
    says why there is none."""
    eq = equation(model, v0 if v0 is not None else free_run_v0(model))
    shape = Shape.of(eq)
    program = Program.of(eq, model.rig.position, shape).arrays()
    return Simulator(eq, model.rig.position, shape, program, *compiled(shape))
