"""Mean force and log-likelihood of the SLS muscle model, for a batch of walkers.

Mean force (a standard linear solid with a Prony series of m Maxwell arms):

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
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from hmid.models.sls._data import SLSData
from hmid.models.sls._recursion import SCAN, unit_response
from hmid.models.sls._space import SLSSpace

_LOG_2PI = math.log(2.0 * math.pi)


def force(space: SLSSpace, theta: jax.Array, data: SLSData, scan: str = SCAN) -> jax.Array:
    """Model muscle force (N) for theta of shape (W, D): shape (n, W)."""
    mech = space.mechanics(theta)
    g = unit_response(data.t, data.x, data.start, mech.tau, scan)  # (n, W, m)
    q = jnp.einsum("nwm,wm->nw", g, mech.k2) if space.arms > 1 else g[..., 0] * mech.k2[:, 0]
    x = data.x[:, None]
    spring = mech.k1 * x + (mech.k3 * x**3 if space.spring == "cubic" else 0.0)
    return mech.A_eff * data.P[:, None] + mech.F0 - spring - q


def chained(use: jax.Array, start: jax.Array) -> jax.Array:
    """Samples whose predecessor is used and in the same log (AR(1) conditional terms)."""
    previous = jnp.concatenate([jnp.zeros(1, bool), use[:-1]])
    return use & previous & ~start


def gaussian_iid(r: jax.Array, sigma: jax.Array, use: jax.Array) -> jax.Array:
    """Sum over used samples of log N(r_k; 0, sigma²); r (n, ...) and sigma (...) -> (...)."""
    use = use.reshape(use.shape + (1,) * (r.ndim - 1))
    ssr = jnp.sum(jnp.where(use, r * r, 0.0), axis=0)
    n = jnp.sum(use)
    return -0.5 * ssr / sigma**2 - n * (jnp.log(sigma) + 0.5 * _LOG_2PI)


def gaussian_ar1(
    r: jax.Array, sigma: jax.Array, phi: jax.Array, use: jax.Array, chain: jax.Array
) -> jax.Array:
    """AR(1) log-likelihood of the used residuals (see the module); r (n, ...) -> (...)."""
    expand = (...,) + (None,) * (r.ndim - 1)
    use, chain = use[expand], chain[expand]
    previous = jnp.concatenate([jnp.zeros_like(r[:1]), r[:-1]], axis=0)
    e = jnp.where(chain, r - phi * previous, r)
    # a run's first sample has variance sigma² / (1 - phi²); the others sigma²
    weight = jnp.where(chain, 1.0, 1.0 - phi**2)
    quad = jnp.sum(jnp.where(use, weight * e * e, 0.0), axis=0)
    n, n_first = jnp.sum(use), jnp.sum(use & ~chain)
    return (
        -0.5 * quad / sigma**2
        + 0.5 * n_first * jnp.log1p(-(phi**2))
        - n * (jnp.log(sigma) + 0.5 * _LOG_2PI)
    )


def log_likelihood(space: SLSSpace, theta: jax.Array, data: SLSData, scan: str = SCAN) -> jax.Array:
    """Log-likelihood of theta (W, D) given the used samples of ``data``: shape (W,)."""
    residual = data.F[:, None] - force(space, theta, data, scan)  # (n, W)
    sigma, phi = space.noise_params(theta)
    if space.noise == "iid":
        return gaussian_iid(residual, sigma, data.use)
    return gaussian_ar1(residual, sigma, phi, data.use, chained(data.use, data.start))
