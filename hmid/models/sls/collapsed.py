"""The exact SLS posterior for one Maxwell arm: the parameters that enter linearly integrated out.

Given the relaxation time tau (and, for AR(1) noise, phi) the force is linear in
beta = (A_eff, F0, k1, [k3], k2): F = X(tau) beta + r, the columns of X those of
:class:`~hmid.models.sls.terms.SLSForce`. With a flat prior on beta and
p(sigma) ∝ 1/sigma, the marginal posterior of (tau, phi) is, up to a constant,

    p(tau, phi | F) ∝ p(tau) p(phi) (1 - phi²)^(n1/2) |X̃ᵀX̃|^(-1/2) S(tau, phi)^(-(n - p)/2)

where X̃ and ỹ are X and F through the AR(1) filter (e_k = r_k - phi r_{k-1} on chained samples,
sqrt(1 - phi²) r_k on the n1 samples that open a run; none for i.i.d. noise), S is the least-
squares residual sum of squares and p the number of linear parameters. p(tau) and p(phi) are
the priors of :class:`~hmid.models.sls.SLSSpace` (ln tau ~ N(ln 0.1 s, 3), phi uniform).

The marginal is evaluated on a grid in ln tau (and atanh phi) that spans 8 posterior standard
deviations either side of the mode at ten points per standard deviation. Draws are exact and
independent: a cell of the grid by its mass (jittered within it), then sigma² = S / chi²(n - p)
and beta ~ N(beta_hat, sigma² (X̃ᵀX̃)⁻¹): the effective sample size is the number of draws.
Every X̃ᵀX̃ is the Gram matrix of columns scaled to unit RMS, so its conditioning is that of the
physics, not of the units. One arm only: several arms need a grid per arm (use the MCMC path).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from hmid.errors import ConfigError
from hmid.models.sls._data import SLSData
from hmid.models.sls._sampler_result import SamplerResult
from hmid.models.sls._space import PHI_MAX, SLSSpace
from hmid.models.sls.likelihood import chained
from hmid.signal.maxwell import responses

POINTS_PER_SD = 10
HALF_WIDTH_SD = 8.0
_PHI_COARSE = 201  # atanh-phi points of the first, whole-range pass


@dataclass(frozen=True)
class PosteriorGrid:
    """The marginal posterior on its grid: ln tau (T,), atanh phi (U,) and log density (T, U)."""

    log_tau: np.ndarray
    atanh_phi: np.ndarray
    log_density: np.ndarray

    def marginal(self, axis: str) -> tuple[np.ndarray, np.ndarray]:
        """(coordinate, normalised density) of ``"tau"`` (in s) or ``"phi"``."""
        weight = np.exp(self.log_density - self.log_density.max())
        if axis == "tau":
            density = weight.sum(axis=1)
            return np.exp(self.log_tau), density / np.trapezoid(density, self.log_tau)
        density = weight.sum(axis=0)
        return np.tanh(self.atanh_phi), density / max(np.trapezoid(density, self.atanh_phi), 1e-300)


class _Gram:
    """Gram matrices of Z = [fixed columns, -g_tau, F] / scale over the rows each term needs."""

    def __init__(self, space: SLSSpace, data: SLSData):
        fixed = space.force.fixed_columns(data.P, data.x, data.x3)
        self.use = np.asarray(data.use)
        self.start = np.asarray(data.start)
        y = np.asarray(data.F)
        block = np.column_stack([*fixed, y])
        rms = np.sqrt(np.mean(block[self.use] ** 2, axis=0))
        self.scale = np.where(rms > 0, rms, 1.0)
        self.block = block / self.scale  # [fixed..., y], scaled
        self.p0 = len(fixed)
        chain = np.asarray(chained(jnp.asarray(self.use), jnp.asarray(self.start)))
        self.chain = np.flatnonzero(chain)
        self.first = np.flatnonzero(self.use & ~chain)
        self.rows = np.flatnonzero(self.use)
        self.n = int(self.use.sum())

    def _gram(self, c: np.ndarray, ra: np.ndarray, rb: np.ndarray) -> np.ndarray:
        """Z[ra]ᵀ Z[rb] for every arm column of c (n, G): (G, q, q), order [fixed, arm, y]."""
        a, b, ca, cb = self.block[ra], self.block[rb], c[ra], c[rb]
        p0, q, g = self.p0, self.p0 + 2, c.shape[1]
        aa, ac, ca_ = a.T @ b, a.T @ cb, ca.T @ b
        cc = np.einsum("kg,kg->g", ca, cb)
        out = np.empty((g, q, q))
        out[:, :p0, :p0] = aa[:p0, :p0]
        out[:, :p0, q - 1] = aa[:p0, p0]
        out[:, q - 1, :p0] = aa[p0, :p0]
        out[:, q - 1, q - 1] = aa[p0, p0]
        out[:, :p0, p0] = ac[:p0].T
        out[:, q - 1, p0] = ac[p0]
        out[:, p0, :p0] = ca_[:, :p0]
        out[:, p0, q - 1] = ca_[:, p0]
        out[:, p0, p0] = cc
        return out

    def matrices(self, g: np.ndarray, ar1: bool):
        """(M0, M1, M2, arm scales) with M(phi) = M0 - phi M1 + phi² M2 (M1 = M2 = None for
        i.i.d. noise)."""
        scale = self.scale_arm(g)
        c = -g / scale
        m0 = self._gram(c, self.rows, self.rows)
        if not ar1:
            return m0, None, None, scale
        k, before = self.chain, self.chain - 1
        lag = self._gram(c, k, before)
        m1 = lag + np.swapaxes(lag, 1, 2)
        m2 = self._gram(c, before, before) - self._gram(c, self.first, self.first)
        return m0, m1, m2, scale

    def scale_arm(self, g: np.ndarray) -> np.ndarray:
        rms = np.sqrt(np.mean(g[self.use] ** 2, axis=0))
        return np.where(rms > 0, rms, 1.0)


def _log_marginal(m: np.ndarray, n: int, n_first: int, phi: np.ndarray):
    """log |A|^(-1/2) S^(-(n-p)/2) (1 - phi²)^(n1/2) for augmented Grams m (..., q, q); also the
    Cholesky factors. -inf where the Gram is not positive definite."""
    q = m.shape[-1]
    p = q - 1
    out = np.full(m.shape[:-2], -np.inf)
    chol = np.zeros_like(m)
    flat_m, flat_out, flat_chol = m.reshape(-1, q, q), out.reshape(-1), chol.reshape(-1, q, q)
    try:
        flat_chol[...] = np.linalg.cholesky(flat_m)
        good = np.ones(len(flat_m), bool)
    except np.linalg.LinAlgError:
        good = np.zeros(len(flat_m), bool)
        for i, one in enumerate(flat_m):
            try:
                flat_chol[i] = np.linalg.cholesky(one)
                good[i] = True
            except np.linalg.LinAlgError:
                pass
    diag = np.diagonal(flat_chol, axis1=1, axis2=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        logdet = 2.0 * np.sum(np.log(diag[:, :p]), axis=1)
        log_s = 2.0 * np.log(diag[:, p])
        value = -0.5 * logdet - 0.5 * (n - p) * log_s
    phi = np.broadcast_to(phi, out.shape).reshape(-1)
    value = value + 0.5 * n_first * np.log1p(-(phi**2))
    flat_out[good] = np.where(np.isfinite(value[good]), value[good], -np.inf)
    return out, chol


class _Posterior:
    """The marginal of (ln tau, atanh phi) on any grid, with the scans it needs."""

    def __init__(self, space: SLSSpace, data: SLSData):
        if space.arms != 1:
            raise ConfigError(
                f"the exact SLS posterior integrates one Maxwell arm, not {space.arms}; use "
                "posterior: mcmc"
            )
        self.space, self.data, self.gram = space, data, _Gram(space, data)
        self.ar1 = space.noise == "ar1"
        _, mean, sd = space.gaussian_prior()
        i = space.index("log_tau")
        self.prior_tau = (float(mean[i]), float(sd[i]))

    def arms(self, log_tau: np.ndarray) -> np.ndarray:
        d = self.data
        return responses(d.t, d.x, d.start, np.exp(np.asarray(log_tau)))  # (n, T)

    def evaluate(self, log_tau: np.ndarray, atanh_phi: np.ndarray):
        """Log density (T, U) and what the draws need at each point."""
        g = self.arms(log_tau)
        m0, m1, m2, arm_scale = self.gram.matrices(g, self.ar1)
        phi = np.tanh(atanh_phi) if self.ar1 else np.zeros(1)
        if self.ar1:
            m = (m0[:, None] - phi[None, :, None, None] * m1[:, None]
                 + phi[None, :, None, None] ** 2 * m2[:, None])  # fmt: skip
        else:
            m = m0[:, None]
        n_first = len(self.gram.first) if self.ar1 else 0
        value, chol = _log_marginal(m, self.gram.n, n_first, phi[None, :])
        mu, sd = self.prior_tau
        value = value - 0.5 * ((log_tau[:, None] - mu) / sd) ** 2
        if self.ar1:
            inside = np.abs(atanh_phi) < math.atanh(PHI_MAX)
            log_jac = np.log1p(-(phi**2))  # phi = tanh(u) uniform: density (1 - phi²) in u
            value = value + np.where(inside, log_jac, -np.inf)[None, :]
        return value, chol, arm_scale


def _mode_1d(f, centre: float, step: float, points: int = 17, tries: int = 12):
    """Mode and curvature sd of a 1-D log density f(grid) by widening local grids."""
    for _ in range(tries):
        grid = centre + step * np.arange(-(points // 2), points // 2 + 1)
        value = f(grid)
        best = int(np.argmax(value))
        if not np.isfinite(value[best]):
            step *= 4.0
            continue
        if best in (0, len(grid) - 1):
            centre = grid[best]
            step *= 2.0
            continue
        lo, hi = max(best - 2, 0), min(best + 3, len(grid))
        a, b, _ = np.polyfit(grid[lo:hi], value[lo:hi], 2)
        if a >= 0:
            step *= 2.0
            continue
        mode, sd = -b / (2 * a), 1.0 / math.sqrt(-2 * a)
        if sd < step / 3:  # the peak is narrower than the grid: look closer
            centre, step = mode, max(sd, 1e-9)
            continue
        return mode, sd
    raise ConfigError(
        "exact SLS posterior: no mode found for the relaxation time; use posterior: mcmc"
    )


def _grid(
    posterior: _Posterior, tau0: float, phi0: float
) -> tuple[PosteriorGrid, np.ndarray, np.ndarray]:
    """The grid around the mode: first along ln tau (phi profiled), then both axes."""
    coarse_u = np.linspace(-math.atanh(PHI_MAX), math.atanh(PHI_MAX), _PHI_COARSE)[1:-1]

    def profile(log_tau):
        u = coarse_u if posterior.ar1 else np.zeros(1)
        value, _, _ = posterior.evaluate(np.asarray(log_tau), u)
        return value.max(axis=1)

    mode, sd = _mode_1d(profile, math.log(tau0), 0.05)
    u_mode, u_sd = 0.0, 1.0
    if posterior.ar1:

        def along_u(u):
            value, _, _ = posterior.evaluate(np.array([mode]), np.asarray(u))
            return value[0]

        u_mode, u_sd = _mode_1d(along_u, math.atanh(np.clip(phi0, -0.9, 0.9)), 0.05)
    half = HALF_WIDTH_SD
    for _ in range(4):
        n_tau = 2 * int(half * POINTS_PER_SD) + 1
        log_tau = mode + sd * np.linspace(-half, half, n_tau)
        if posterior.ar1:
            top = math.atanh(PHI_MAX) - 1e-9
            u = np.clip(u_mode + u_sd * np.linspace(-half, half, n_tau), -top, top)
            u = np.unique(u)
        else:
            u = np.zeros(1)
        value, chol, arm_scale = posterior.evaluate(log_tau, u)
        peak = value.max()
        edges = [value[0].max(), value[-1].max()]
        if posterior.ar1:
            edges += [value[:, 0].max(), value[:, -1].max()]
        if max(edges) < peak - 25.0:  # e^-25: the box holds the mass
            return PosteriorGrid(log_tau, u, value), chol, arm_scale
        half *= 1.5  # a skewed or wider posterior than the curvature said
    return PosteriorGrid(log_tau, u, value), chol, arm_scale


def exact_posterior(
    space: SLSSpace, data: SLSData, tau0: float, *, phi0: float = 0.0, draws: int = 4000,
    seed: int = 0,
) -> tuple[SamplerResult, PosteriorGrid]:  # fmt: skip
    """Independent draws of the one-arm SLS posterior (see the module docstring), in the
    coordinates of ``space`` (which must have ``linear="identity"``), and the grid."""
    if space.linear != "identity":
        raise ConfigError("exact_posterior: needs SLSSpace(linear='identity') coordinates")
    start = time.perf_counter()
    posterior = _Posterior(space, data)
    grid, chol, arm_scale = _grid(posterior, tau0, phi0)
    gram = posterior.gram
    rng = np.random.default_rng(np.random.SeedSequence([seed, 14]))
    weight = np.exp(grid.log_density - grid.log_density.max()).ravel()
    cells = rng.choice(weight.size, size=draws, p=weight / weight.sum())
    it, iu = np.unravel_index(cells, grid.log_density.shape)
    p = space.force.n_linear  # A_eff, F0, k1, [k3], k2
    factor = chol[it, iu]  # (draws, p + 1, p + 1): A = L Lᵀ, its last row [b, s]
    upper = np.swapaxes(factor[:, :p, :p], 1, 2)
    beta_hat = np.linalg.solve(upper, factor[:, p, :p, None])[..., 0]
    sigma = factor[:, p, p] / np.sqrt(rng.chisquare(gram.n - p, size=draws))
    noise = np.linalg.solve(upper, rng.standard_normal((draws, p, 1)))[..., 0]
    beta = beta_hat + sigma[:, None] * noise
    scales = np.column_stack([np.broadcast_to(gram.scale[: gram.p0], (draws, gram.p0)),
                              arm_scale[it]])  # fmt: skip
    jitter = rng.uniform(-0.5, 0.5, size=(draws, 2))
    step_tau = grid.log_tau[1] - grid.log_tau[0] if len(grid.log_tau) > 1 else 0.0
    step_u = grid.atanh_phi[1] - grid.atanh_phi[0] if len(grid.atanh_phi) > 1 else 0.0
    theta = np.empty((draws, space.dim))
    theta[:, :p] = beta * gram.scale[-1] / scales
    theta[:, p] = grid.log_tau[it] + step_tau * jitter[:, 0]
    theta[:, p + 1] = np.log(sigma * gram.scale[-1])
    if space.noise == "ar1":
        theta[:, p + 2] = grid.atanh_phi[iu] + step_u * jitter[:, 1]
    log_prob = grid.log_density[it, iu]
    result = SamplerResult(
        names=space.names,
        chain=theta,
        log_prob=log_prob,
        acceptance=np.array([1.0]),
        tau=np.ones(space.dim),
        ess=np.full(space.dim, float(draws)),
        n_steps=draws,
        burn_in=0,
        thin=1,
        stop_reason="exact",
        wall_s=time.perf_counter() - start,
        backend_path=None,
        walkers=theta[:, None, :],
        walkers_log_prob=log_prob[:, None],
        tau_history=np.empty((0, space.dim + 1)),
        n_nan=0,
    )
    return result, grid
