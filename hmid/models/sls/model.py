"""The SLS muscle model: configuration, jitted mean force, likelihood, prior and posterior.

``SLSModel(spring="cubic", arms=1, noise="iid")`` is an immutable, hashable configuration; its
methods call functions jitted with the model static and the data (:class:`SLSData`) as an
argument, so a new data set of the same length reuses the compiled code, and one of another
length compiles once more. All computation is float64 (``jax.enable_x64``) whatever the global
setting; nothing is traced at import.

theta is either one point (D,) or a batch of walkers (W, D): the likelihood, prior and posterior
return a scalar or a (W,) array accordingly (``jax.Array``; ``numpy.asarray`` is free on CPU).
:meth:`SLSModel.log_prob` maps every non-finite value (NaN theta, overflowing parameters) to
-inf, so samplers reject such proposals instead of propagating NaN.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property, partial
from typing import Literal

import jax
import jax.numpy as jnp
import numpy as np

from hmid.errors import ConfigError
from hmid.models.sls import likelihood as _lik
from hmid.models.sls._data import SLSData
from hmid.models.sls._space import SLSSpace
from hmid.signal.maxwell import SCAN


@partial(jax.jit, static_argnums=(0, 3))
def _force(space: SLSSpace, theta, data: SLSData, scan: str):
    return _lik.force(space, theta, data, scan)


@partial(jax.jit, static_argnums=(0, 3))
def _log_likelihood(space: SLSSpace, theta, data: SLSData, scan: str):
    return _lik.log_likelihood(space, theta, data, scan)


@partial(jax.jit, static_argnums=0)
def _log_prior(space: SLSSpace, theta):
    return space.log_prior(theta)


@partial(jax.jit, static_argnums=(0, 3))
def _log_prob(space: SLSSpace, theta, data: SLSData, scan: str):
    lp = space.log_prior(theta) + _lik.log_likelihood(space, theta, data, scan)
    return jnp.where(jnp.isfinite(lp), lp, -jnp.inf)


@dataclass(frozen=True)
class SLSModel:
    """Standard-linear-solid muscle force with ``arms`` Maxwell arms; see the module docstring.

    ``spring``: ``"linear"`` or ``"cubic"`` (adds k3 x³); ``noise``: ``"iid"`` or ``"ar1"``
    Gaussian residuals. ``space`` holds theta's names, units, transforms and the prior.
    """

    spring: Literal["linear", "cubic"] = "cubic"
    arms: int = 1
    noise: Literal["iid", "ar1"] = "iid"
    linear: Literal["log", "identity"] = "log"  # coordinates of the force parameters (SLSSpace)

    def __post_init__(self) -> None:
        _ = self.space  # validates the configuration

    @cached_property
    def space(self) -> SLSSpace:
        return SLSSpace(self.spring, self.arms, self.noise, self.linear)

    # -- helpers --------------------------------------------------------------------------------
    def _theta(self, theta) -> tuple[jax.Array, bool]:
        """theta as a float64 (W, D) array and whether it was a single point."""
        if isinstance(theta, Mapping):
            theta = self.theta_from(theta)
        theta = jnp.asarray(theta, dtype=jnp.float64)
        if theta.ndim not in (1, 2) or theta.shape[-1] != self.space.dim:
            raise ConfigError(
                f"{self!r}: theta has shape {tuple(theta.shape)}; expected (D,) or (W, D) with "
                f"D = {self.space.dim} coordinates {list(self.space.names)}"
            )
        return (theta[None], True) if theta.ndim == 1 else (theta, False)

    def theta_from(self, physical: Mapping[str, float]) -> np.ndarray:
        """theta from physical values; sigma defaults to 1 N and phi to 0 when absent."""
        values = {"sigma": 1.0, "phi": 0.0, **physical}
        return np.asarray(self.space.from_physical(values), dtype=np.float64)

    # -- the model ------------------------------------------------------------------------------
    def predict(self, theta, data: SLSData, *, scan: str = SCAN) -> np.ndarray:
        """Mean muscle force (N) at every sample, shape (n,) (or (n, W) for a batch).

        ``theta`` is a point (D,), a batch (W, D), or a mapping of physical values by name
        (``A_eff``, ``F0``, ``k1``, [``k3``], ``k2``/``tau`` or ``k2_i``/``tau_i``).
        """
        with jax.enable_x64(True):
            batch, single = self._theta(theta)
            out = np.asarray(_force(self.space, batch, data, scan))
        return out[:, 0] if single else out

    def log_likelihood(self, theta, data: SLSData, *, scan: str = SCAN) -> jax.Array:
        """log p(F | theta) over the used samples: scalar for (D,), shape (W,) for (W, D)."""
        with jax.enable_x64(True):
            batch, single = self._theta(theta)
            out = _log_likelihood(self.space, batch, data, scan)
        return out[0] if single else out

    def log_prior(self, theta) -> jax.Array:
        """The weakly-informative prior of :class:`SLSSpace` (density in theta)."""
        with jax.enable_x64(True):
            batch, single = self._theta(theta)
            out = _log_prior(self.space, batch)
        return out[0] if single else out

    def log_prob(self, theta, data: SLSData, *, scan: str = SCAN) -> jax.Array:
        """Log posterior density up to a constant; -inf (never NaN) where not finite."""
        with jax.enable_x64(True):
            batch, single = self._theta(theta)
            out = _log_prob(self.space, batch, data, scan)
        return out[0] if single else out

    def log_prob_fn(self, data: SLSData) -> Callable[[np.ndarray], np.ndarray]:
        """``theta (W, D) -> log_prob (W,)`` as float64 NumPy, bound to ``data`` (for emcee)."""

        def log_prob(theta: np.ndarray) -> np.ndarray:
            return np.asarray(self.log_prob(theta, data), dtype=np.float64)

        return log_prob

    def residuals(self, theta, data: SLSData) -> np.ndarray:
        """F - predicted force at every sample (unused samples are 0), shape (n,)."""
        force = self.predict(theta, data)
        return np.where(np.asarray(data.use), np.asarray(data.F) - force, 0.0)
