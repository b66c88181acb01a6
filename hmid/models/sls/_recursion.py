"""Exact discretisation of the Maxwell arms for piecewise-linear elongation.

Between samples k and k+1 the elongation is taken as linear, so the velocity v_k = (x_{k+1} -
x_k) / dt_k is constant and  dq/dt = -q/tau + k2 v  has the exact solution

    q_{k+1} = a_k q_k + b_k,   a_k = exp(-dt_k / tau),   b_k = k2 tau (1 - a_k) v_k,

for any (uneven) dt_k and any tau > 0. Because q is linear in k2, the arms are computed for unit
k2 (the response g_tau) and scaled afterwards. At the first sample of each log a = b = 0 (q
restarts from rest, no velocity across the boundary).

The recursion is an affine first-order recurrence, so it is evaluated with a parallel prefix
(``jax.lax.associative_scan`` with the composition of affine maps) in O(log n) depth. A plain
sequential ``lax.scan`` and a two-level blocked scan are kept for the benchmark
(``benchmarks/bench_sls_likelihood.py``), which measured the associative scan fastest.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def intervals(t: jax.Array, x: jax.Array, start: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(dt, v)`` of the interval that ends at each sample; dt = 0, v = 0 at a log start.

    The first sample is always a start. dt = 0 makes a = 1 - which is then masked by
    :func:`coefficients` - and never divides: v is taken with a safe denominator.
    """
    keep = ~start.at[0].set(True)
    dt = jnp.where(keep, jnp.diff(t, prepend=t[:1]), 0.0)
    v = jnp.where(keep, jnp.diff(x, prepend=x[:1]) / jnp.where(keep, dt, 1.0), 0.0)
    return dt, v


def coefficients(dt: jax.Array, v: jax.Array, tau: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Per-sample ``(a, b)`` for unit k2 and relaxation times ``tau`` of shape (m,) -> (m, n).

    At a log start (dt = 0, v = 0) a is forced to 0 so the state restarts from rest.
    """
    tau = tau[:, None]
    decay = jnp.expm1(-dt / tau)  # a - 1, accurate for dt << tau
    a = jnp.where(dt > 0, 1.0 + decay, 0.0)
    b = -tau * decay * v
    return a, b


def _combine(left, right):
    a1, b1 = left
    a2, b2 = right
    return a1 * a2, a2 * b1 + b2


def scan_associative(a: jax.Array, b: jax.Array) -> jax.Array:
    """q_k = a_k q_{k-1} + b_k along the last axis (q_{-1} = 0), by parallel prefix."""
    return jax.lax.associative_scan(_combine, (a, b), axis=-1)[1]


def scan_sequential(a: jax.Array, b: jax.Array) -> jax.Array:
    """The same recurrence with a plain ``lax.scan`` over time (reference, benchmark)."""

    def step(q, ab):
        q = ab[0] * q + ab[1]
        return q, q

    _, q = jax.lax.scan(step, jnp.zeros(a.shape[:-1], a.dtype), (jnp.moveaxis(a, -1, 0),
                                                                   jnp.moveaxis(b, -1, 0)))
    return jnp.moveaxis(q, 0, -1)


def scan_blocked(a: jax.Array, b: jax.Array, block: int = 128) -> jax.Array:
    """The same recurrence in two levels: sequential inside blocks (all blocks at once), then
    sequential over block boundaries, then a vectorised correction (benchmark variant)."""
    n = a.shape[-1]
    nb = -(-n // block)
    pad = [(0, 0)] * (a.ndim - 1) + [(0, nb * block - n)]
    a_p = jnp.pad(a, pad, constant_values=1.0).reshape(*a.shape[:-1], nb, block)
    b_p = jnp.pad(b, pad).reshape(*b.shape[:-1], nb, block)

    def inner(carry, ab):
        q, prod = carry
        q = ab[0] * q + ab[1]
        prod = prod * ab[0]
        return (q, prod), (q, prod)

    zeros = jnp.zeros(a_p.shape[:-1], a.dtype)
    _, (q_loc, prod) = jax.lax.scan(
        inner, (zeros, jnp.ones_like(zeros)),
        (jnp.moveaxis(a_p, -1, 0), jnp.moveaxis(b_p, -1, 0)),
    )  # fmt: skip
    q_loc, prod = jnp.moveaxis(q_loc, 0, -1), jnp.moveaxis(prod, 0, -1)
    # state entering each block: q_in[j] = prod_end[j-1] q_in[j-1] + q_loc_end[j-1]
    entering = scan_sequential(prod[..., -1], q_loc[..., -1])
    q_in = jnp.concatenate([jnp.zeros_like(entering[..., :1]), entering[..., :-1]], axis=-1)
    q = q_loc + prod * q_in[..., None]
    return q.reshape(*a.shape[:-1], nb * block)[..., :n]


SCANS = {
    "associative": scan_associative,
    "sequential": scan_sequential,
    "blocked": scan_blocked,
}


def unit_response(
    t: jax.Array, x: jax.Array, start: jax.Array, tau: jax.Array, scan: str = "associative"
) -> jax.Array:
    """g_tau for each tau (shape (m,)): the arm force per unit k2, shape (m, n), in m."""
    dt, v = intervals(t, x, start)
    a, b = coefficients(dt, v, tau)
    return SCANS[scan](a, b)
