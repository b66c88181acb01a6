"""An equation of motion as arrays (:class:`Program`), and its vector field in JAX.

Tracing and compiling diffrax costs seconds; running a model, milliseconds. So the compiled
solvers (:mod:`~hmid.portable.freerun.integrator`) never see a model: they see its parts as
arrays of a padded :class:`Shape` (parts to a multiple of :data:`PARTS`, inputs, memory arms and
lags to a power of two), and every model of that shape, of any family, runs through one
compiled program: the demo's six models share one.

Time inside the program is the sample index s (sample k at s = k, the log's own step dt_k
between samples k and k + 1, so a logger's jitter is honoured): the inputs are read at s by one
index and a cubic Hermite between its neighbours, never by a search, and the vector field is
dy/ds = f(t, y) dt_k.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np

from hmid.portable.freerun.equation import Equation, NotSimulable

#: The kinds of a part of the balance, in the order of :class:`Program`'s flags.
TERM_KINDS = ("mono", "tanh", "memory", "lag", "delay", "friction", "accel")
#: Parts are padded to a multiple of this, powers to this degree
PARTS, DEGREE = 24, 4


def _bucket(n: int, least: int = 1) -> int:
    """``n`` rounded up to a power of two, at least ``least``."""
    size = least
    while size < n:
        size *= 2
    return size


class Shape(NamedTuple):
    """What a compiled program depends on: parts, inputs, memory arms, lags, delays, and the
    friction's distinct regularisation velocities."""

    parts: int
    inputs: int
    memory: int
    lags: int
    delays: bool
    scales: int = 1

    @classmethod
    def of(cls, eq: Equation) -> Shape:
        n = len(eq.rhs) + len(eq.lhs)
        delays = any(kind == "delay" for kind, _, _ in eq.rhs)
        return cls(-(-n // PARTS) * PARTS, _bucket(len(eq.inputs)), _bucket(eq.n_memory),
                   _bucket(len(eq.lags)), delays, _bucket(len(_scales(eq))))  # fmt: skip


def _scales(eq: Equation) -> list[float]:
    """The distinct regularisation velocities of the equation's friction parts (tanh(v / v0)),
    in order of appearance: usually one, the run's v0."""
    scales = [data if kind == "tanh" else data[2]
              for kind, data, _ in (*eq.rhs, *eq.lhs) if kind in ("tanh", "friction")]  # fmt: skip
    return list(dict.fromkeys(scales))


@dataclass(frozen=True)
class Program:
    """An equation's parts as arrays: ``side`` +1 on the model side, -1 on the explained side, 0
    for padding; ``flags`` one row per kind of :data:`TERM_KINDS`; ``powers`` the exponents of x, v
    and the inputs; ``scales`` the distinct regularisation velocities of the friction parts
    (tanh and the free-fall law), ``scale_of`` each part's; the rest each kind's data. Padded
    memory arms, lags and scales are states or velocities that no part reads."""

    side: np.ndarray
    flags: np.ndarray
    powers: np.ndarray
    scales: np.ndarray
    scale_of: np.ndarray
    memory: np.ndarray
    lag: np.ndarray
    delay_input: np.ndarray
    delay: np.ndarray
    friction: np.ndarray
    lag_input: np.ndarray  # the input each first-order lag follows

    @classmethod
    def of(cls, eq: Equation, position: str, shape: Shape) -> Program:
        parts = [(+1, p) for p in eq.rhs] + [(-1, p) for p in eq.lhs]
        n = shape.parts
        channels = ["x", "v", *eq.inputs]
        lag_input = np.zeros(shape.lags, dtype=np.int32)
        lag_input[: len(eq.lags)] = [eq.inputs.index(name) for name, _ in eq.lags]
        out: dict[str, Any] = {
            "side": np.zeros(n), "flags": np.zeros((len(TERM_KINDS), n)),
            "powers": np.zeros((n, 2 + shape.inputs), dtype=np.int32),
            "scales": np.ones(shape.scales), "scale_of": np.zeros(n, dtype=np.int32),
            "memory": np.zeros(n, dtype=np.int32), "lag": np.zeros(n, dtype=np.int32),
            "delay_input": np.zeros(n, dtype=np.int32), "delay": np.zeros(n),
            "friction": np.zeros((n, 2)), "lag_input": lag_input,
        }  # fmt: skip
        scales = _scales(eq)
        out["scales"][: len(scales)] = scales
        for i, (side, (kind, data, _)) in enumerate(parts):
            out["side"][i] = side
            if kind == "const":
                kind = "mono"
            out["flags"][TERM_KINDS.index(kind), i] = 1.0
            if kind == "mono" and data is not None:
                for name, power in _rename(data, position):
                    if power > DEGREE:
                        raise NotSimulable(f"a power {power} above {DEGREE} in the balance")
                    out["powers"][i, channels.index(name)] += power
            elif kind == "tanh":
                out["scale_of"][i] = scales.index(data)
            elif kind == "memory":
                out["memory"][i] = data[0]
            elif kind == "lag":
                out["lag"][i] = data
            elif kind == "delay":
                out["delay_input"][i], out["delay"][i] = eq.inputs.index(data[0]), data[1]
            elif kind == "friction":
                out["friction"][i] = data[:2]
                out["scale_of"][i] = scales.index(data[2])
        return cls(**out)

    def arrays(self) -> tuple[np.ndarray, ...]:
        return tuple(getattr(self, f.name) for f in fields(self))


def _rename(data, position: str):
    """The position channel is called "x" inside the integrator."""
    if isinstance(data, tuple) and data and isinstance(data[0], tuple):
        return tuple(("x" if c == position else c, p) for c, p in data)
    return data


def _weights(w, flags, memory, lag_of, scale_of, friction, shape: Shape):
    """Each kind's weight on its regressors: w (a part's signed coefficient) folded. The
    friction parts fold onto their scales' tanh(v / v0) and |v| tanh(v / v0) (a free-fall law
    Fc + b |v| onto both), so that a step evaluates one tanh per distinct scale, not one per
    padded part (on the linear stage, where a step is a few vector field evaluations, the
    padded parts' tanh were a third of the free run's time)."""
    import jax
    import jax.numpy as jnp

    to_scale = jax.nn.one_hot(scale_of, shape.scales, dtype=w.dtype)
    return (
        w * flags[0],
        (w * flags[1] + w * flags[5] * friction[:, 0]) @ to_scale,
        (w * flags[2]) @ jax.nn.one_hot(memory, shape.memory, dtype=w.dtype),
        (w * flags[3]) @ jax.nn.one_hot(lag_of, shape.lags, dtype=w.dtype),
        w * flags[4], (w * flags[5] * friction[:, 1]) @ to_scale, jnp.sum(w * flags[6]),
    )  # fmt: skip


def _prepare(shape: Shape, program, dts, count, table, coef, taus, lag_times) -> dict[str, Any]:
    """The coefficients folded into per-kind weights, once per run (see :func:`vector_field`)."""
    import jax.numpy as jnp

    (side, flags, powers, scales, scale_of, memory, lag_of, delay_input, delay, friction,
     lag_input) = program  # fmt: skip
    mean_step = jnp.sum(jnp.where(jnp.arange(dts.shape[0]) < count - 1, dts, 0.0)) / (
        count - 1)  # fmt: skip
    signed = side * coef
    return {
        "dts": dts, "count": count, "rows": _rows(table, dts, count), "powers": powers,
        "scales": scales,
        "delay": delay / mean_step, "delay_input": delay_input, "taus": taus,
        "lag_times": lag_times, "lag_input": lag_input,
        "model": _weights(signed, flags, memory, lag_of, scale_of, friction, shape),
        "explained": _weights(jnp.where(side < 0, signed, 0.0), flags, memory, lag_of,
                              scale_of, friction, shape),
    }  # fmt: skip


def _at(s, table, count):
    """The table's columns at sample time s, linear between samples; and the sample."""
    import jax.numpy as jnp

    k = jnp.clip(jnp.floor(s).astype(jnp.int32), 0, count - 2)
    w = s - k
    return table[..., k] * (1 - w) + table[..., k + 1] * w, k


def _smooth_at(s, table, count):
    """The table's columns at sample time s, a cubic Hermite (Catmull-Rom) between samples; and
    the sample. The inputs are read so: read linearly, they have a kink at every sample, where
    an error-controlled step is rejected and shrinks to a sample (42 % of the steps were
    rejected on the bench's SLS run); read smoothly, the same tolerance takes half the steps
    (22,784 -> 10,787 on a 40 s log at 500 Hz). Both agree at the samples."""
    import jax.numpy as jnp

    k = jnp.clip(jnp.floor(s).astype(jnp.int32), 0, count - 2)
    return _cubic(s - k, *_knots(table, k, count)), k


def _knots(table, k, count):
    """The values and Catmull-Rom slopes at the ends of the samples ``k``'s intervals."""
    import jax.numpy as jnp

    y0, y1 = table[..., k], table[..., k + 1]
    m0 = (y1 - table[..., jnp.maximum(k - 1, 0)]) / jnp.where(k > 0, 2.0, 1.0)
    m1 = (table[..., jnp.minimum(k + 2, count - 1)] - y0) / jnp.where(k + 2 <= count - 1, 2.0, 1.0)
    return y0, m0, y1, m1


def _cubic(w, y0, m0, y1, m1):
    """The cubic Hermite at ``w`` in [0, 1] between (y0, m0) and (y1, m1)."""
    h00, h10, h01, h11 = (
        2 * w**3 - 3 * w**2 + 1,
        w**3 - 2 * w**2 + w,
        -2 * w**3 + 3 * w**2,
        w**3 - w**2,
    )
    return h00 * y0 + h10 * m0 + h01 * y1 + h11 * m1


def _rows(table, dts, count):
    """Per sample k, one row: the inputs' knots of the interval k to k + 1 (:func:`_knots`, as
    columns: values, slopes, next values, next slopes) and the step dts[k]. Computed once per
    run, so that a vector field evaluation reads its inputs by one gather of a row: read from
    the table, the slopes were kernels of their own, two of the four an evaluation launched
    (a step's kernels 49 -> 36), and a step took twice the time (the bench's linear stage
    33-40 -> 18-20 ms of CPU, the SLS 48 -> 22 ms)."""
    import jax.numpy as jnp

    k = jnp.minimum(jnp.arange(dts.shape[0]), count - 2)
    return jnp.concatenate([*_knots(table, k, count), dts[None, k]]).T


def _powers(z, n):
    """z (channels) to the integer powers n (parts, channels), by their binary digits: z, z^2,
    z^4 chosen elementwise (a one-hot contraction over the degrees cost a fifth of a step)."""
    import jax.numpy as jnp

    out, square = 1.0, z
    for bit in range(DEGREE.bit_length()):
        out = out * jnp.where((n >> bit) & 1, square, 1.0)
        square = square * square
    return out


def _total(shape: Shape, s, y, now, p, table, weights):
    """The weighted sum of the parts that do not hold a, and the coefficient of a."""
    import jax
    import jax.numpy as jnp

    m = shape.memory
    mono, tanh_w, memory_w, lag_w, delay_w, abs_w, accel = weights
    x, v = y[0], y[1]
    z = jnp.concatenate([jnp.stack([x, v]), now])
    monomials = jnp.prod(_powers(z, p["powers"]), axis=1)
    value = (
        jnp.dot(mono, monomials) + jnp.dot(tanh_w + abs_w * jnp.abs(v), jnp.tanh(v / p["scales"]))
        + jnp.dot(memory_w, y[2 : 2 + m]) + jnp.dot(lag_w, y[2 + m :])
    )  # fmt: skip
    if shape.delays:
        late = jax.vmap(lambda d, i: _smooth_at(s - d, table, p["count"])[0][i])(
            p["delay"], p["delay_input"])  # fmt: skip
        value = value + jnp.dot(delay_w, late)
    return value, accel


def vector_field(shape: Shape):
    """``(prepare, field, explained)`` for programs of ``shape``. ``prepare(program, dts, count,
    table, coef, taus, lag_times)`` folds the coefficients into per-kind weights and the inputs
    into one row of knots per sample (:func:`_rows`) once per run (the loop then does no gathers
    but the inputs' row); ``field(s, y, args)`` is dy/ds at sample time s
    with ``args = (prepared, table, noise)``, ``table`` the inputs (rows) and ``noise`` the
    disturbance force at the samples; ``explained(s, y, args)`` the explained quantity the state
    implies."""
    import jax.numpy as jnp

    m = shape.memory

    def prepare(program, dts, count, table, coef, taus, lag_times):
        return _prepare(shape, program, dts, count, table, coef, taus, lag_times)

    def rates(s, y, args):
        """dy/dt, the acceleration solved from the balance (the disturbance a force on the
        model side); and the step dt/ds there."""
        p, table, noise = args
        n = shape.inputs
        k = jnp.clip(jnp.floor(s).astype(jnp.int32), 0, p["count"] - 2)
        row = p["rows"][k]
        now = _cubic(s - k, row[:n], row[n : 2 * n], row[2 * n : 3 * n], row[3 * n : 4 * n])
        force = _at(s, noise, p["count"])[0]
        value, accel = _total(shape, s, y, now, p, table, p["model"])
        a = -(value + force) / accel
        dq = -y[2 : 2 + m] / p["taus"] + y[1]
        dlag = (now[p["lag_input"]] - y[2 + m :]) / p["lag_times"]
        return jnp.concatenate([jnp.stack([y[1], a]), dq, dlag]), row[4 * n], now

    def field(s, y, args):
        dy, dt, _ = rates(s, y, args)
        return dy * dt

    def explained(s, y, args):
        p, table, _ = args
        dy, _, now = rates(s, y, args)
        value, accel = _total(shape, s, y, now, p, table, p["explained"])
        return -value - accel * dy[1]

    return prepare, field, explained
