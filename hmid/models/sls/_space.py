"""The SLS parameter space: unconstrained coordinates theta, physical values, units and prior.

theta = (log A_eff, F0, log k1, [log k3], log k2_1, log tau_1, ..., log k2_m, log tau_m,
log sigma, [atanh phi]). Positive parameters are sampled on the log scale (one unit is one
e-fold), F0 as is (newtons), the AR(1) coefficient phi through atanh, so every coordinate is
unbounded and of order one over its plausible range - a well-conditioned space for MCMC and
least squares alike.

The prior (:meth:`SLSSpace.log_prior`, a proper density in theta) is weakly informative:

* each log-parameter ~ Normal(log centre, 3 e-folds) with centres A_eff 2e-4 m², k1 3e3 N/m,
  k3 1e6 N/m³, k2 1e3 N/m, sigma 0.05 N (the thesis's rig: core bore ~ 1e-4 m², latex core
  k ~ 6e3 N/m, force resolution 0.01 N), and tau log-spaced between 0.01 s and 1 s over the arms
  (0.1 s for a single arm);
* F0 ~ Normal(0, 50 N);
* phi ~ Uniform(-0.99, 0.99) (the density of atanh phi carries the Jacobian 1 - phi²);
* with several arms, tau_1 < tau_2 < ... (the prior is zero otherwise, times m! to stay proper):
  it removes the label switching of a Prony series, whose likelihood is symmetric in the arms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from hmid.errors import ConfigError
from hmid.models.sls.terms import SLSForce

PRIOR_SD = 3.0  # e-folds, for every log-parameter
F0_SD = 50.0  # N
PHI_MAX = 0.99
_CENTRES = {"A_eff": 2.0e-4, "k1": 3.0e3, "k3": 1.0e6, "k2": 1.0e3, "sigma": 0.05}
_NOISE_UNITS = {"sigma": "N", "phi": "1"}  # the force parameters' are in .terms


class Mechanics(NamedTuple):
    """Physical force-model parameters; leading (walker) shape of theta, arms on the last axis."""

    A_eff: jax.Array | np.ndarray
    F0: jax.Array | np.ndarray
    k1: jax.Array | np.ndarray
    k3: jax.Array | np.ndarray  # zeros for a linear spring
    k2: jax.Array | np.ndarray  # (..., arms)
    tau: jax.Array | np.ndarray  # (..., arms)


def _xp(value):
    return jnp if isinstance(value, jax.Array) else np


@dataclass(frozen=True)
class SLSSpace:
    """Coordinates of one SLS configuration; see the module docstring for the prior.

    ``spring`` is ``"linear"`` (k1 x) or ``"cubic"`` (k1 x + k3 x³); ``arms`` the number of
    Maxwell arms (k2_i, tau_i) of the Prony series; ``noise`` ``"iid"`` or ``"ar1"``.
    """

    spring: Literal["linear", "cubic"] = "cubic"
    arms: int = 1
    noise: Literal["iid", "ar1"] = "iid"
    #: "log": the positive force parameters sampled on the log scale (emcee); "identity": as
    #: they are, the coordinates of the exact posterior (:mod:`.collapsed`), whose flat prior
    #: lets the data, not the coordinates, decide their signs
    linear: Literal["log", "identity"] = "log"

    def __post_init__(self) -> None:
        if self.linear not in ("log", "identity"):
            raise ConfigError(f"SLS linear={self.linear!r}: use 'log' or 'identity'")
        if self.spring not in ("linear", "cubic"):
            raise ConfigError(f"SLS spring={self.spring!r}: use 'linear' or 'cubic'")
        if isinstance(self.arms, bool) or not isinstance(self.arms, int | np.integer):
            raise ConfigError(f"SLS arms={self.arms!r}: must be an integer >= 1")
        if self.arms < 1:
            raise ConfigError(f"SLS arms={self.arms}: need at least one Maxwell arm")
        if self.noise not in ("iid", "ar1"):
            raise ConfigError(f"SLS noise={self.noise!r}: use 'iid' or 'ar1'")
        object.__setattr__(self, "arms", int(self.arms))

    # -- names ----------------------------------------------------------------------------------
    @property
    def force(self) -> SLSForce:
        """The force's linear parameters and columns (:mod:`.terms`)."""
        return SLSForce(self.spring, self.arms)

    def arm_names(self) -> list[tuple[str, str]]:
        """``(k2, tau)`` physical names of each arm: ``k2``/``tau`` or ``k2_i``/``tau_i``."""
        return self.force.arm_names()

    @property
    def physical_names(self) -> tuple[str, ...]:
        """The fixed linear parameters, each arm's (k2, tau), sigma and [phi]."""
        names = [p.name for p in self.force.fixed]
        for k2, tau in self.arm_names():
            names += [k2, tau]
        return (*names, "sigma", *(("phi",) if self.noise == "ar1" else ()))

    def is_log(self, name: str) -> bool:
        """Whether physical parameter ``name`` has a log coordinate."""
        if name in ("F0", "phi"):
            return False
        return name.startswith(("tau", "sigma")) or self.linear == "log"

    @property
    def names(self) -> tuple[str, ...]:
        """theta's coordinate names: ``log_<p>`` for log coordinates, ``atanh_phi``, else the
        physical name."""
        return tuple(
            "atanh_phi" if p == "phi" else f"log_{p}" if self.is_log(p) else p
            for p in self.physical_names
        )

    @property
    def units(self) -> tuple[str, ...]:
        """Units of :attr:`physical_names`, in the same order."""
        units = {p.name: p.unit for p in self.force.linear} | _NOISE_UNITS
        units |= {tau: "s" for _, tau in self.arm_names()}
        return tuple(units[p] for p in self.physical_names)

    @property
    def dim(self) -> int:
        return len(self.physical_names)

    def index(self, name: str) -> int:
        """Position of a theta or physical name in theta."""
        for names in (self.names, self.physical_names):
            if name in names:
                return names.index(name)
        raise ConfigError(f"SLS has no parameter {name!r}; it has {list(self.physical_names)}")

    # -- transforms -----------------------------------------------------------------------------
    def to_physical(self, theta) -> dict[str, jax.Array | np.ndarray]:
        """Physical values by name; theta of shape (..., D) gives arrays of shape (...)."""
        xp = _xp(theta)
        theta = xp.asarray(theta)
        self._check_dim(theta)
        out = {}
        for i, p in enumerate(self.physical_names):
            value = theta[..., i]
            out[p] = xp.tanh(value) if p == "phi" else xp.exp(value) if self.is_log(p) else value
        return out

    def from_physical(self, physical) -> np.ndarray | jax.Array:
        """theta (..., D) from physical values by name (every physical name is required)."""
        missing = [p for p in self.physical_names if p not in physical]
        if missing:
            raise ConfigError(
                f"SLS from_physical: missing {missing}; need {list(self.physical_names)}"
            )
        xp = jnp if any(isinstance(v, jax.Array) for v in physical.values()) else np
        columns = []
        for p in self.physical_names:
            value = xp.asarray(physical[p], dtype=float)
            columns.append(xp.arctanh(value) if p == "phi" else xp.log(value) if self.is_log(p)
                           else value)  # fmt: skip
        return xp.stack(columns, axis=-1)

    def mechanics(self, theta) -> Mechanics:
        """The force-model parameters of theta (..., D) (no noise parameters)."""
        xp = _xp(theta)
        phys = self.to_physical(theta)
        arms = self.arm_names()
        k3 = phys["k3"] if self.spring == "cubic" else xp.zeros_like(phys["k1"])
        return Mechanics(
            phys["A_eff"], phys["F0"], phys["k1"], k3,
            xp.stack([phys[k2] for k2, _ in arms], axis=-1),
            xp.stack([phys[tau] for _, tau in arms], axis=-1),
        )  # fmt: skip

    def noise_params(self, theta) -> tuple:
        """``(sigma, phi)`` of theta (..., D); phi is 0 for iid noise."""
        xp = _xp(theta)
        sigma = xp.exp(theta[..., self.index("sigma")])
        phi = xp.tanh(theta[..., -1]) if self.noise == "ar1" else xp.zeros_like(sigma)
        return sigma, phi

    # -- prior ----------------------------------------------------------------------------------
    def prior_centre(self) -> np.ndarray:
        """theta at the centre of the prior (phi = 0); also a fallback starting point."""
        taus = [0.1] if self.arms == 1 else np.geomspace(0.01, 1.0, self.arms)
        centre = dict(_CENTRES, F0=0.0, phi=0.0)
        for (k2, tau), value in zip(self.arm_names(), taus, strict=True):
            centre[k2], centre[tau] = _CENTRES["k2"], float(value)
        return np.asarray(self.from_physical({p: centre[p] for p in self.physical_names}))

    def gaussian_prior(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mask, mean and sd of the coordinates with a Gaussian prior (all but atanh phi, and
        the force parameters' identity coordinates, whose prior is flat)."""
        mean = self.prior_centre()
        gaussian = np.array([self.is_log(p) or (p == "F0" and self.linear == "log")
                             for p in self.physical_names])  # fmt: skip
        sd = np.where(np.array([p == "F0" for p in self.physical_names]), F0_SD, PRIOR_SD)
        return gaussian, mean, sd

    def log_prior(self, theta) -> jax.Array:
        """Log prior density of theta (..., D) -> (...); -inf outside the support or for NaN."""
        with jax.enable_x64(True):
            return self._log_prior(jnp.asarray(theta, dtype=jnp.float64))

    def _log_prior(self, theta: jax.Array) -> jax.Array:
        self._check_dim(theta)
        gaussian, mean, sd = self.gaussian_prior()
        z = (theta - mean) / sd
        terms = -0.5 * z**2 - np.log(sd) - 0.5 * math.log(2 * math.pi)
        lp = jnp.sum(jnp.where(gaussian, terms, 0.0), axis=-1)
        if self.noise == "ar1":
            u = theta[..., -1]
            # phi = tanh(u) ~ U(-PHI_MAX, PHI_MAX): density (1 - tanh(u)^2) / (2 PHI_MAX)
            log_sech2 = 2.0 * (math.log(2.0) - jnp.abs(u) - jnp.log1p(jnp.exp(-2.0 * jnp.abs(u))))
            inside = jnp.abs(u) < math.atanh(PHI_MAX)
            lp = lp + jnp.where(inside, log_sech2 - math.log(2 * PHI_MAX), -jnp.inf)
        if self.arms > 1:
            log_tau = theta[..., [self.index(tau) for _, tau in self.arm_names()]]
            ordered = jnp.all(jnp.diff(log_tau, axis=-1) > 0, axis=-1)
            lp = jnp.where(ordered, lp + math.lgamma(self.arms + 1), -jnp.inf)
        return jnp.where(jnp.isnan(lp), -jnp.inf, lp)

    def _check_dim(self, theta) -> None:
        if theta.ndim == 0 or theta.shape[-1] != self.dim:
            raise ConfigError(
                f"SLS theta has shape {tuple(theta.shape)}; its last axis must hold the "
                f"{self.dim} coordinates {list(self.names)}"
            )
