"""A robust starting point for the SLS model: a tau grid of linear fits, then Levenberg-Marquardt.

For fixed relaxation times the mean force is *linear* in the other parameters,

    F = A_eff P + F0 - k1 x - k3 x³ - sum_i k2_i g_{tau_i}(x),

where g_tau is the arm force per unit k2 (:mod:`hmid.signal.maxwell`); the design is the SLS's
terms (:class:`.terms.SLSForce`), the one place it is written. :func:`initial_fit` therefore

1. evaluates g_tau on a log-spaced grid (1 ms to 10 s, 40 points by default) and, for every grid
   point (every increasing m-tuple of a thinned grid for m arms), solves the linear least squares
   for the rest: the spring/pressure columns are projected out once (QR), leaving an m x m
   problem per tuple; tuples whose k2 are all positive are preferred;
2. refits the best tuple's linear coefficients on the full design; a positive parameter that
   comes out <= 0 (k3 on data that look linear, k2 of a superfluous arm) is clipped to
   ``centre * exp(-2 * PRIOR_SD)`` of its prior and a note says so;
3. refines the force parameters jointly with ``optimistix.LevenbergMarquardt`` on the residual
   vector in theta space: the used residuals divided by the grid fit's residual std, stacked with
   the prior's Gaussian terms (theta - centre) / sd. With sigma fixed this is the posterior mode
   of the force parameters; the prior terms weigh ~1/n of the data and only keep directions the
   data do not determine (k3 -> 0, a vanishing arm) from drifting to -inf in log space;
4. sets sigma from the final residuals (their std; for ``noise="ar1"`` phi is their lag-1
   autocorrelation over consecutive used samples and sigma the innovation std, so the stationary
   std equals the residual std).

A solver that does not report success raises :class:`StartError` with optimistix's message and
the best grid point; a result is otherwise always ``successful``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from hmid.errors import ConfigError, HmidError
from hmid.models.sls import likelihood as _lik
from hmid.models.sls._data import SLSData
from hmid.models.sls._space import PRIOR_SD, SLSSpace
from hmid.models.sls.model import SLSModel

MAX_TUPLES = 2000  # grid tuples examined for several arms (the grid is thinned to stay below)
PHI_START_MAX = 0.95


class StartError(HmidError, RuntimeError):
    """The starting-point optimisation did not converge."""


@dataclass(frozen=True)
class StartResult:
    """Outcome of :func:`initial_fit`.

    ``theta`` (D,) in the model's coordinates and ``physical`` the same values by name;
    ``residual_std`` (N) of the used residuals at ``theta``; ``tau_profile`` = ``(grid, sse)``,
    the tau tuples tried (shape (G, arms), seconds) and the sum of squared residuals of each
    linear fit; ``status``/``message`` and ``n_steps`` from Levenberg-Marquardt; ``notes`` says
    what was clipped or adjusted.
    """

    theta: np.ndarray
    physical: dict[str, float]
    residual_std: float
    tau_profile: tuple[np.ndarray, np.ndarray]
    status: str
    message: str
    n_steps: int
    notes: tuple[str, ...] = field(default=())


def _tau_tuples(grid: np.ndarray, arms: int) -> np.ndarray:
    """Increasing ``arms``-tuples of (a thinned) grid, as indices, shape (T, arms)."""
    size = len(grid)
    while size > arms and math.comb(size, arms) > MAX_TUPLES:
        size -= 1
    keep = np.unique(np.round(np.linspace(0, len(grid) - 1, size)).astype(int))
    return np.array(list(itertools.combinations(keep, arms)), dtype=int).reshape(-1, arms)


def _design(space: SLSSpace, data: SLSData, grid: np.ndarray):
    """The SLS's terms (:meth:`.terms.SLSForce.terms`) on ``data``: the columns of those without a
    relaxation time, their names, and an arm's column (its sign built in) for every tau."""
    import pandas as pd

    from hmid.balance import Signals, Structure
    from hmid.balance.operations import memory_arms

    segment = np.cumsum(np.asarray(data.start)) - 1
    frame = pd.DataFrame({"log": segment, "segment": segment, "t": np.asarray(data.t),
                          "x": np.asarray(data.x), "P": np.asarray(data.P),
                          "target": np.asarray(data.F), "train": np.asarray(data.use)})  # fmt: skip
    signals = Signals.from_frame(frame, {"x": "m", "P": "Pa", "target": "N"}, position="x")
    terms = space.force.terms()
    linear = Structure.of([t for t in terms if t.hyper is None]).columns(signals)
    values, names = np.array(linear.values), list(linear.names)
    if "k3" in names:  # the data's cube (smoothed where x is), as the likelihood reads it
        values[:, names.index("k3")] = -np.asarray(data.x3)
    arms = -memory_arms(signals, "x", tuple(float(g) for g in grid)).T  # k2 enters as -k2 g
    return values, names, arms


def _lstsq_scaled(design: np.ndarray, y: np.ndarray) -> np.ndarray:
    scale = np.linalg.norm(design, axis=0)
    scale[scale == 0] = 1.0
    coef = np.linalg.lstsq(design / scale, y, rcond=None)[0]
    return coef / scale


def _grid_search(space: SLSSpace, data: SLSData, grid: np.ndarray):
    """Best tau tuple on the grid and the linear coefficients there."""
    used = np.asarray(data.use)
    y = np.asarray(data.F)[used]
    base, names, g = _design(space, data, grid)
    base, g = base[used], g[used]
    q, _ = np.linalg.qr(base / np.maximum(np.linalg.norm(base, axis=0), 1e-300))
    y_perp = y - q @ (q.T @ y)
    arms = g - q @ (q.T @ g)  # columns of the k2's, spring and pressure projected out
    norms = np.linalg.norm(arms, axis=0)
    norms[norms == 0] = 1.0
    arms_n = arms / norms
    gram, cross = arms_n.T @ arms_n, arms_n.T @ y_perp
    tuples = _tau_tuples(grid, space.arms)
    sub_gram = gram[tuples[:, :, None], tuples[:, None, :]]  # (T, m, m)
    sub_cross = cross[tuples]  # (T, m)
    beta = np.einsum("tij,tj->ti", np.linalg.pinv(sub_gram, rcond=1e-12), sub_cross)
    sse = float(y_perp @ y_perp) - np.einsum("ti,ti->t", beta, sub_cross)
    sse = np.maximum(sse, 0.0)
    k2 = beta / norms[tuples]
    feasible = np.all(k2 > 0, axis=1)
    pool = np.flatnonzero(feasible) if feasible.any() else np.arange(len(tuples))
    best = int(pool[np.argmin(sse[pool])])
    chosen = tuples[best]
    coef = _lstsq_scaled(np.concatenate([base, g[:, chosen]], axis=1), y)
    linear = dict(zip(names, coef[: len(names)], strict=True))
    return grid[tuples], sse, best, linear, coef[len(names) :], grid[chosen]


@partial(jax.jit, static_argnums=(0, 4, 5, 6))
def _refine(space: SLSSpace, data: SLSData, theta0, scale, rtol, atol, max_steps):
    """LM on theta's force coordinates: used residuals / scale, stacked with prior z-scores."""
    n_force = theta0.shape[0]
    _, prior_mean, prior_sd = space.gaussian_prior()  # every force coordinate has a Gaussian prior
    mean, sd = jnp.asarray(prior_mean[:n_force]), jnp.asarray(prior_sd[:n_force])
    noise = jnp.zeros(space.dim - n_force)

    def residuals(theta_force, data):
        theta = jnp.concatenate([theta_force, noise])[None]
        r = jnp.where(data.use, data.F - _lik.force(space, theta, data)[:, 0], 0.0) / scale
        return jnp.concatenate([r, (theta_force - mean) / sd])

    solver: optx.LevenbergMarquardt[jax.Array, jax.Array, None]
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol: optx.Solution[jax.Array, None]
    sol = optx.least_squares(residuals, solver, theta0, args=data, max_steps=max_steps, throw=False)
    return sol.value, sol.result, sol.stats["num_steps"]


def initial_fit(
    data: SLSData,
    model: SLSModel,
    *,
    tau_grid=None,
    rtol: float = 1e-6,
    atol: float = 1e-6,
    max_steps: int = 256,
) -> StartResult:
    """Starting point for ``model`` on ``data``: tau-grid linear fits refined by LM (module doc).

    ``tau_grid`` (s, positive) defaults to 40 log-spaced points from 1 ms to 10 s. ``rtol`` and
    ``atol`` are Levenberg-Marquardt's tolerances on theta and on the objective (optimistix's
    Cauchy criterion); 1e-6 is ample for a starting point and lets near-degenerate fits (two
    arms on one-arm data, where the arms merge along a flat valley) converge.
    Raises :class:`StartError` if Levenberg-Marquardt does not report success.
    """
    space = model.space
    grid = _checked_grid(space, tau_grid)
    tuples, sse, best, linear, k2, taus = _grid_search(space, data, grid)
    notes: list[str] = []
    physical = _positive_start(space, linear, k2, taus, notes)
    n_used = int(np.sum(np.asarray(data.use)))
    scale = max(math.sqrt(float(sse[best]) / n_used), 1e-12)
    physical.update(sigma=scale, phi=0.0)
    theta0 = np.asarray(space.from_physical(physical))
    n_force = space.index("sigma")
    best_text = ", ".join(f"{t:.4g}" for t in taus)
    with jax.enable_x64(True):
        value, result, steps = _refine(
            space, data, jnp.asarray(theta0[:n_force]), scale, rtol, atol, max_steps
        )
        ok = bool(result == optx.RESULTS.successful)
        message = optx.RESULTS[result] or "converged"  # type: ignore[misc]  # equinox's metaclass
    if not ok:
        raise StartError(
            f"initial_fit: Levenberg-Marquardt did not converge after {int(steps)} steps: "
            f"{message} Best grid point: tau = ({best_text}) s with residual std "
            f"{scale:.4g} N; raise the sls family's start_max_steps (now {max_steps}) in the "
            "config's models section, or check the data"
        )
    theta = theta0.copy()
    theta[:n_force] = np.asarray(value)
    theta, sorted_note = _order_arms(space, theta)
    if sorted_note:
        notes.append(sorted_note)
    theta, residual_std = _noise_start(model, data, theta)
    physical = {k: float(v) for k, v in space.to_physical(theta).items()}
    return StartResult(
        theta=theta, physical=physical, residual_std=residual_std,
        tau_profile=(tuples, sse), status="successful", message=message,
        n_steps=int(steps), notes=tuple(notes),
    )  # fmt: skip


def _checked_grid(space: SLSSpace, tau_grid) -> np.ndarray:
    """The sorted distinct taus (s) of ``tau_grid``, by default 40 log-spaced from 1 ms to 10 s."""
    grid = np.geomspace(1e-3, 10.0, 40) if tau_grid is None else np.asarray(tau_grid, float)
    if grid.ndim != 1 or len(grid) < space.arms or not np.all(np.isfinite(grid) & (grid > 0)):
        raise ConfigError(
            f"initial_fit: tau_grid needs at least {space.arms} positive finite times (s), "
            f"got {grid!r}"
        )
    return np.unique(grid)


def _positive_start(space: SLSSpace, linear, k2, taus, notes: list[str]) -> dict[str, float]:
    """The best grid point's physical parameters; one the prior keeps positive that the linear
    fit made not positive starts two prior widths below the prior's centre (noted in ``notes``)."""
    centre = space.to_physical(space.prior_centre())
    physical = dict(linear)
    for i, (name, tau_name) in enumerate(space.arm_names()):
        physical[name], physical[tau_name] = float(k2[i]), float(taus[i])
    for name in [p for p in space.physical_names if p not in ("F0", "sigma", "phi")]:
        if not physical[name] > 0:
            floor = float(centre[name]) * math.exp(-2 * PRIOR_SD)
            notes.append(
                f"{name} = {physical[name]:.4g} from the linear fit is not positive; "
                f"started at {floor:.3g} instead"
            )
            physical[name] = floor
    return physical


def _order_arms(space: SLSSpace, theta: np.ndarray) -> tuple[np.ndarray, str | None]:
    """Sort the arms by tau (the prior's order); the likelihood is symmetric in them."""
    arms = space.arm_names()
    if len(arms) < 2:
        return theta, None
    pairs = [(space.index(k2), space.index(tau)) for k2, tau in arms]
    values = [(theta[j], theta[i]) for i, j in pairs]
    order = sorted(range(len(values)), key=lambda i: values[i][0])
    if order == list(range(len(values))):
        return theta, None
    out = theta.copy()
    for (i, j), src in zip(pairs, order, strict=True):
        out[j], out[i] = values[src]
    return out, "arms re-ordered by increasing tau (the prior's labelling)"


def _noise_start(model: SLSModel, data: SLSData, theta: np.ndarray) -> tuple[np.ndarray, float]:
    space = model.space
    r = model.residuals(theta, data)
    use = np.asarray(data.use)
    residual_std = float(np.sqrt(np.mean(r[use] ** 2)))
    sigma = residual_std
    theta = theta.copy()
    if space.noise == "ar1":
        with jax.enable_x64(True):
            chain = np.asarray(_lik.chained(data.use, data.start))
        prev = np.concatenate([[0.0], r[:-1]])
        phi = float(np.sum(r[chain] * prev[chain]) / max(np.sum(prev[chain] ** 2), 1e-300))
        phi = float(np.clip(phi, -PHI_START_MAX, PHI_START_MAX))
        sigma = residual_std * math.sqrt(1.0 - phi**2)
        theta[-1] = math.atanh(phi)
    theta[space.index("sigma")] = math.log(max(sigma, 1e-12))
    return theta, residual_std
