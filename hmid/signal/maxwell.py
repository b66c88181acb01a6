"""Exact discretisation of the Maxwell arms for piecewise-linear elongation.

Between samples k-1 and k the elongation is taken as linear, so the velocity v_k = (x_k -
x_{k-1}) / dt_k is constant and  dq/dt = -q/tau + k2 v  has the exact solution

    q_k = a_k q_{k-1} + b_k,   a_k = exp(-dt_k / tau),   b_k = k2 tau (1 - a_k) v_k,

for any (uneven) dt_k and any tau > 0. Because q is linear in k2, the arms are computed for unit
k2 (the response g_tau, in metres) and scaled afterwards. At the first sample of each log
a = b = 0: q restarts from rest and no velocity is taken across the boundary.

Arrays are time-major: for relaxation times ``tau`` of any shape (walkers, arms) the response has
shape ``(n, *tau.shape)``, so each time step reads one contiguous row. The recurrence is affine
and first order; three evaluations are kept, all exact to rounding:

* ``"sequential"``: one ``lax.scan`` over time, all walkers and arms in the carry;
* ``"associative"``: ``lax.associative_scan`` (parallel prefix, O(log n) depth) with the
  composition of affine maps;
* ``"blocked"``: a scan inside blocks of ``BLOCK`` samples (all blocks at once), a scan over block
  boundaries, and a vectorised correction.

``benchmarks/bench_sls_likelihood.py`` times them: for 20,000 samples x 32 walkers on the 2-core
CPU the whole likelihood took ~4-7 ms with the sequential scan, ~7-14 ms with the associative scan
and ~5-9 ms blocked (ranges over machine load). XLA's loop costs ~0.1 µs per step here, while the
parallel prefix sweeps the (n, W) arrays ~2 log2(n) times, so the sequential scan is the default
:data:`SCAN`. All three agree to rounding (~1e-16 relative).
"""

from __future__ import annotations

from functools import cache

import jax
import jax.numpy as jnp
import numpy as np

BLOCK = 64


def intervals(t: jax.Array, x: jax.Array, start: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(dt, v)`` of the interval that ends at each sample, shape (n,); 0 and 0 at a log start.

    The first sample is always a start; v is taken with a safe denominator, so a time base that
    restarts between logs never divides by zero.
    """
    keep = ~start.at[0].set(True)
    dt = jnp.where(keep, jnp.diff(t, prepend=t[:1]), 0.0)
    v = jnp.where(keep, jnp.diff(x, prepend=x[:1]) / jnp.where(keep, dt, 1.0), 0.0)
    return dt, v


def coefficients(dt: jax.Array, v: jax.Array, tau: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(a, b)`` for unit k2, shape ``dt.shape + tau.shape``; a = b = 0 where dt = 0 (start)."""
    expand = (...,) + (None,) * tau.ndim
    dt, v = dt[expand], v[expand]
    decay = jnp.expm1(-dt / tau)  # a - 1, accurate for dt << tau
    return jnp.where(dt > 0, 1.0 + decay, 0.0), -tau * decay * v


def _sequential(a: jax.Array, b: jax.Array, q0: jax.Array | None = None) -> jax.Array:
    def step(q, ab):
        q = ab[0] * q + ab[1]
        return q, q

    q0 = jnp.zeros(a.shape[1:], a.dtype) if q0 is None else q0
    return jax.lax.scan(step, q0, (a, b))[1]


def _combine(left, right):
    a1, b1 = left
    a2, b2 = right
    return a1 * a2, a2 * b1 + b2


def scan_sequential(
    dt: jax.Array, v: jax.Array, tau: jax.Array, q0: jax.Array | None = None
) -> jax.Array:
    """g_tau by one ``lax.scan`` over time, from the state ``q0`` (default 0) before ``dt[0]``."""
    return _sequential(*coefficients(dt, v, tau), q0)


def scan_associative(dt: jax.Array, v: jax.Array, tau: jax.Array) -> jax.Array:
    """g_tau by parallel prefix (``lax.associative_scan``) over time."""
    return jax.lax.associative_scan(_combine, coefficients(dt, v, tau), axis=0)[1]


def scan_blocked(dt: jax.Array, v: jax.Array, tau: jax.Array, block: int = BLOCK) -> jax.Array:
    """g_tau in two levels: inside blocks of ``block`` samples, then across block boundaries."""
    n = dt.shape[0]
    nb = -(-n // block)

    def blocks(z):  # (n,) -> (block, nb): row j holds the j-th sample of every block
        return jnp.pad(z, (0, nb * block - n)).reshape(nb, block).T

    a, b = coefficients(blocks(dt), blocks(v), tau)  # (block, nb, *tau.shape)

    def inner(carry, ab):
        q, prod = carry
        q, prod = ab[0] * q + ab[1], prod * ab[0]
        return (q, prod), (q, prod)

    zeros = jnp.zeros(a.shape[1:], a.dtype)
    (q_end, prod_end), (q_loc, prod) = jax.lax.scan(inner, (zeros, jnp.ones_like(zeros)), (a, b))
    entering = _sequential(prod_end, q_end)  # state at the end of each block
    q_in = jnp.concatenate([jnp.zeros_like(entering[:1]), entering[:-1]], axis=0)
    q = q_loc + prod * q_in[None]
    return jnp.swapaxes(q, 0, 1).reshape(nb * block, *tau.shape)[:n]


SCANS = {
    "sequential": scan_sequential,
    "associative": scan_associative,
    "blocked": scan_blocked,
}
SCAN = "sequential"


def unit_response(
    t: jax.Array, x: jax.Array, start: jax.Array, tau: jax.Array | np.ndarray, scan: str = SCAN
) -> jax.Array:
    """g_tau, the Maxwell-arm force per unit k2 (m), shape ``(n, *tau.shape)``."""
    dt, v = intervals(t, x, start)
    return SCANS[scan](dt, v, jnp.asarray(tau))


@cache
def compiled_response():
    """:func:`unit_response` compiled whole, once per shape. Called eagerly it dispatches each of
    its operations as a program of its own, traced and compiled (or loaded) for every new shape
    of ``tau``: tens of milliseconds a call, where the compiled scan takes one."""
    return jax.jit(unit_response, static_argnames="scan")


def responses(t, x, start, taus, batch: int = 16) -> np.ndarray:
    """g_tau for each of ``taus`` (1-D), shape ``(n, len(taus))``, in float64: the compiled scan
    on ``batch`` taus at a time (the last batch padded), so that each log length compiles one
    program however many taus are asked for."""
    taus = np.asarray(taus, dtype=float).ravel()
    response = compiled_response()
    with jax.enable_x64(True):
        t, x, start = (jnp.asarray(a) for a in (t, x, start))
        parts = []
        for lo in range(0, len(taus), batch):
            part = taus[lo : lo + batch]
            padded = np.pad(part, (0, batch - len(part)), mode="edge")
            parts.append(np.asarray(response(t, x, start, jnp.asarray(padded)))[:, : len(part)])
    return np.concatenate(parts, axis=1) if parts else np.empty((len(t), 0))
