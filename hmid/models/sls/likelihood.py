"""Mean force and log-likelihood of the SLS muscle model, for a batch of walkers.

Mean force (a standard linear solid with a Prony series of m Maxwell arms, declared in
:mod:`.terms`):

    F_m = A_eff P + F0 - (k1 x + k3 x³ + sum_i q_i),   dq_i/dt = -q_i / tau_i + k2_i dx/dt,

with q_i advanced exactly for piecewise-linear x (:mod:`._recursion`). The residual
r = F - F_m enters on the samples with ``use``:

* ``noise="iid"``: r_k ~ N(0, sigma²);
* ``noise="ar1"``: r_k = phi r_{k-1} + e_k, e_k ~ N(0, sigma²), conditional on r_{k-1} where the
  previous sample is used and in the same log; a sample that opens a run of used samples (a log
  start, or after an unused sample) enters with the stationary variance sigma² / (1 - phi²).

These are pure functions of ``(space, theta, data)``; :class:`~hmid.models.sls.model.SLSModel`
jits them with the configuration static and the data as an argument. Walkers sit on the trailing
axis of the (n, W) intermediate arrays (time-major), so the recursion reads contiguous rows;
``jax.vmap`` of the one-walker function gives the same numbers but was ~35 % slower in
``benchmarks/bench_sls_likelihood.py`` (JAX puts the batch axis first and transposes around the
scan).

With the sequential scan (the default) the time axis is walked in chunks of :data:`CHUNK`
samples, the arm state q (and, for AR(1), the last residual) carried from one chunk to the next:
only (CHUNK, W) intermediates exist at a time, instead of a handful of (n, W) arrays. Whole-array
evaluation ran at ~70 ns per sample (16 walkers) while those arrays fitted in the 32 MB L3 cache
and at ~190 ns beyond (~100,000 samples): one doubling of the log made the likelihood 5x slower
(``benchmarks/bench_scaling.py``). Chunked, the cost per sample stays flat; the numbers agree
with the whole-array evaluation to rounding (sums in another order).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from hmid.models.sls._data import SLSData
from hmid.models.sls._space import SLSSpace
from hmid.signal.maxwell import SCAN, intervals, scan_sequential, unit_response

_LOG_2PI = math.log(2.0 * math.pi)
#: Samples per chunk of the time axis with the sequential scan (see the module docstring).
CHUNK = 8192


def _chunked(space: SLSSpace, theta: jax.Array, data: SLSData, step, init):
    """Walk the time axis in chunks of :data:`CHUNK` samples with the sequential scan.

    ``step(state, force, F, use, chain) -> (state, out)`` sees each chunk's force (C, W) and its
    rows of F, use and :func:`chained` (C,); the zero padding after the last sample has use and
    chain False. Returns the final ``state`` and the ``out`` of every chunk, stacked.
    """
    mech = space.mechanics(theta)
    n = data.t.shape[0]
    chunk = min(CHUNK, n)
    dt, v = intervals(data.t, data.x, data.start)
    columns = (dt, v, data.x, data.x3, data.P, data.F, data.use, chained(data.use, data.start))
    rows = tuple(jnp.pad(c, (0, -n % chunk)).reshape(-1, chunk) for c in columns)

    def body(carry, rows):
        q, state = carry
        dt, v, x, x3, P, F, use, chain = rows
        g = scan_sequential(dt, v, mech.tau, q)  # padding: dt = 0, so a = b = 0
        state, out = step(state, space.force.mean(mech, x, x3, P, g), F, use, chain)
        return (g[-1], state), out

    carry = (jnp.zeros_like(mech.tau), init)
    if rows[0].shape[0] == 1:  # one chunk: no outer loop, the same operations as a whole pass
        (_, state), out = body(carry, tuple(r[0] for r in rows))
        return state, None if out is None else out[None]
    (_, state), out = jax.lax.scan(body, carry, rows)
    return state, out


def force(space: SLSSpace, theta: jax.Array, data: SLSData, scan: str = SCAN) -> jax.Array:
    """Model muscle force (N) for theta of shape (W, D): shape (n, W)."""
    if scan == "sequential":
        _, out = _chunked(space, theta, data, lambda state, f, *_: (state, f), ())
        return out.reshape(-1, theta.shape[0])[: data.t.shape[0]]
    mech = space.mechanics(theta)
    g = unit_response(data.t, data.x, data.start, mech.tau, scan)  # (n, W, m)
    return space.force.mean(mech, data.x, data.x3, data.P, g)


def chained(use: jax.Array, start: jax.Array) -> jax.Array:
    """Samples whose predecessor is used and in the same log (AR(1) conditional terms)."""
    previous = jnp.concatenate([jnp.zeros(1, bool), use[:-1]])
    return use & previous & ~start


def gaussian_iid(r: jax.Array, sigma: jax.Array, use: jax.Array) -> jax.Array:
    """Sum over used samples of log N(r_k; 0, sigma²); r (n, ...) and sigma (...) -> (...)."""
    use = use.reshape(use.shape + (1,) * (r.ndim - 1))
    return _iid(jnp.sum(jnp.where(use, r * r, 0.0), axis=0), jnp.sum(use), sigma)


def _iid(ssr: jax.Array, n: jax.Array, sigma: jax.Array) -> jax.Array:
    return -0.5 * ssr / sigma**2 - n * (jnp.log(sigma) + 0.5 * _LOG_2PI)


def gaussian_ar1(
    r: jax.Array, sigma: jax.Array, phi: jax.Array, use: jax.Array, chain: jax.Array
) -> jax.Array:
    """AR(1) log-likelihood of the used residuals (see the module); r (n, ...) -> (...)."""
    quad = _ar1_quad(r, phi, use, chain, jnp.zeros_like(r[0]))
    return _ar1(quad, sigma, phi, use, chain)


def _ar1_quad(r, phi, use, chain, before) -> jax.Array:
    """The AR(1) quadratic form over rows r (n, ...); ``before`` is the residual before r[0]."""
    expand = (...,) + (None,) * (r.ndim - 1)
    use, chain = use[expand], chain[expand]
    previous = jnp.concatenate([before[None], r[:-1]], axis=0)
    e = jnp.where(chain, r - phi * previous, r)
    # a run's first sample has variance sigma² / (1 - phi²); the others sigma²
    weight = jnp.where(chain, 1.0, 1.0 - phi**2)
    return jnp.sum(jnp.where(use, weight * e * e, 0.0), axis=0)


def _ar1(quad, sigma, phi, use, chain) -> jax.Array:
    n, n_first = jnp.sum(use), jnp.sum(use & ~chain)
    return (
        -0.5 * quad / sigma**2
        + 0.5 * n_first * jnp.log1p(-(phi**2))
        - n * (jnp.log(sigma) + 0.5 * _LOG_2PI)
    )


def log_likelihood(space: SLSSpace, theta: jax.Array, data: SLSData, scan: str = SCAN) -> jax.Array:
    """Log-likelihood of theta (W, D) given the used samples of ``data``: shape (W,)."""
    sigma, phi = space.noise_params(theta)
    if scan == "sequential":  # chunk by chunk: no (n, W) array (see the module docstring)
        zero = jnp.zeros(theta.shape[0], theta.dtype)
        if space.noise == "iid":

            def iid_step(ssr, f, F, use, chain):
                r = F[:, None] - f
                return ssr + jnp.sum(jnp.where(use[:, None], r * r, 0.0), axis=0), None

            ssr, _ = _chunked(space, theta, data, iid_step, zero)
            return _iid(ssr, jnp.sum(data.use), sigma)

        def ar1_step(state, f, F, use, chain):
            quad, before = state
            r = F[:, None] - f
            return (quad + _ar1_quad(r, phi, use, chain, before), r[-1]), None

        (quad, _), _ = _chunked(space, theta, data, ar1_step, (zero, zero))
        return _ar1(quad, sigma, phi, data.use, chained(data.use, data.start))
    residual = data.F[:, None] - force(space, theta, data, scan)  # (n, W)
    if space.noise == "iid":
        return gaussian_iid(residual, sigma, data.use)
    return gaussian_ar1(residual, sigma, phi, data.use, chained(data.use, data.start))
