"""The hierarchical model of a population, sampled by NumPyro's NUTS.

For muscle i and parameter p (in units u_p, the population's typical value, for conditioning)::

    law_ip   = c_p + e_p . (f_i - mean f) + m_p (log E_i - mean log E)       (hmid.population._law)
    y_ip     ~ Normal(law_ip, s_p)               the muscle's own log-parameter (centred form)
    theta_ip = u_p exp(y_ip)                     (F0: y ~ Normal(exp(law), s), theta = u y)
    muscle i's likelihood: theta_i ~ MVN(its SLS posterior mean, its covariance)

with e_p ~ Normal(expected, exponent_sd), c_p ~ Normal(0, intercept_sd), s_p ~
LogNormal(log scatter_typical, scatter_log_sd). Why that prior: with ~8 muscles and four law
coefficients per parameter, the muscles say little about each scatter (~3 degrees of freedom),
so its prior shapes the predictive. A prior flat in s, as a wide half-normal is near zero,
leans the scatter high: the predictive is a Student-t with a degree of freedom fewer than the
regression's own (90 % intervals up to ~50 % wider at 3 degrees of freedom; the former
half-normal(0.3) covered 0.94). The scale-free 1/s (log-uniform) gives the regression's own t,
calibrated for a parameter every muscle pins, but where the muscles' own fits hardly pin it
(a long muscle's k3) the likelihood is flat below their measurement error and 1/s piles the
scatter onto its lower bound (log-uniform from 0.5 %: k3's intervals covered 0.75). The
log-normal is 1/s times a Gaussian in log s: scale-free near a physically plausible
manufacturing scatter of ~10 % (tubing wall and bore tolerances, the latex's batch; 1 sd:
3.7-27 %) and no mass at a scatter no build achieves.

The centred form suits this problem: each muscle's own fit pins its y_i far more tightly than
the scatter does, where a non-centred form would make NUTS crawl along the ridge between y and
the law. Why NUTS and not emcee (the SLS family's sampler): the model
has ~80 coordinates that grow with the muscles, and an ensemble sampler's affine moves mix
poorly in that many dimensions, where gradient-based NUTS needs no tuning; NumPyro gives it on
JAX with ArviZ's R-hat and ESS.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from hmid.errors import HmidError
from hmid.population._law import (
    ADDITIVE,
    FEATURES,
    PARAMETERS,
    expected_matrix,
    feature_matrix,
    offsets,
    spec_features,
)
from hmid.population._summary import MuscleFit
from hmid.simulate.specs import MuscleSpec

_ADDITIVE = np.array([p in ADDITIVE for p in PARAMETERS])


@dataclass(frozen=True)
class Priors:
    """The model's prior scales (see the module docstring)."""

    exponent_sd: float = 0.5
    intercept_sd: float = 3.0
    scatter_typical: float = 0.1
    scatter_log_sd: float = 1.0


@dataclass(frozen=True)
class Sampler:
    """NUTS settings: chains run one after the other on one device."""

    chains: int = 2
    warmup: int = 500
    draws: int = 500
    target_accept: float = 0.95
    seed: int = 0


@dataclass(frozen=True)
class PopulationFit:
    """The population's posterior: the law's intercepts, exponents and scatter, draw by draw."""

    names: tuple[str, ...]
    specs: tuple[MuscleSpec, ...]
    scale: np.ndarray  # (P,) u_p
    center: np.ndarray  # (F,) mean features
    center_offsets: np.ndarray  # (P,)
    intercept: np.ndarray  # (S, P)
    exponent: np.ndarray  # (S, P, F)
    scatter: np.ndarray  # (S, P)
    muscles: np.ndarray  # (S, n, P): each muscle's parameters, physical units
    diagnostics: pd.DataFrame  # ArviZ summary: mean, sd, hdi, ess_bulk, ess_tail, r_hat
    wall_s: float
    cpu_s: float  # this process's CPU time: the wall time on an idle core
    idata: Any = field(repr=False, default=None)  # arviz.InferenceData

    def law_log(self, spec: MuscleSpec) -> np.ndarray:
        """Draws (S, P) of the law's log-value at ``spec`` (in units of ``scale``)."""
        f = spec_features(spec) - self.center
        o = offsets(spec) - self.center_offsets
        return self.intercept + np.einsum("spf,f->sp", self.exponent, f) + o

    def law(self, spec: MuscleSpec) -> np.ndarray:
        """Draws (S, P) of the law's value at ``spec`` (no muscle scatter), physical units."""
        return np.exp(self.law_log(spec)) * self.scale

    def predict(self, spec: MuscleSpec, seed: int = 0) -> np.ndarray:
        """Posterior-predictive draws (S, P) of a new muscle of build ``spec``: the law plus a
        new muscle's scatter, physical units."""
        law = self.law_log(spec)
        z = np.random.default_rng(seed).standard_normal(law.shape)
        scaled = np.where(_ADDITIVE, np.exp(law) + self.scatter * z, np.exp(law + self.scatter * z))
        return scaled * self.scale

    @property
    def converged(self) -> bool:
        """R-hat at most 1.05 and bulk ESS at least 50 for every law coordinate."""
        d = self.diagnostics
        return bool((d["r_hat"] <= 1.05).all() and (d["ess_bulk"] >= 50).all())


def _scale(fits: tuple[MuscleFit, ...]) -> np.ndarray:
    means = np.abs(np.array([f.mean for f in fits]))
    return np.exp(np.mean(np.log(np.maximum(means, 1e-300)), axis=0))


def _model(F, Off, W, m, k, expected, additive, exponent_sd, intercept_sd, scatter_prior):
    import jax.numpy as jnp
    import numpyro
    import numpyro.distributions as dist

    P = m.shape[1]
    c = numpyro.sample("intercept", dist.Normal(jnp.zeros(P), intercept_sd).to_event(1))
    e = numpyro.sample("exponent", dist.Normal(expected, exponent_sd).to_event(2))
    s = numpyro.sample("scatter", _scatter_prior(*scatter_prior, P))
    law = c + F @ e.T + Off
    loc = jnp.where(additive, jnp.exp(law), law)
    # centred (k = 1) where the muscle's own fit pins the parameter, non-centred (k = 0) where
    # it hardly does (k3 of a long muscle): y = loc + s^(1-k) (y_k - k loc), y_k ~ N(k loc, s^k)
    y_k = numpyro.sample("y_k", dist.Normal(k * loc, s**k).to_event(2))
    y = numpyro.deterministic("y", loc + s ** (1 - k) * (y_k - k * loc))
    theta = jnp.where(additive, y, jnp.exp(y))
    z = jnp.einsum("nij,nj->ni", W, theta - m)
    numpyro.factor("muscles", -0.5 * jnp.sum(z**2))


def _scatter_prior(typical, log_sd, P: int):
    """The scatter's prior: log-normal about ``typical``, each parameter's (module docstring)."""
    import jax.numpy as jnp
    import numpyro.distributions as dist

    return dist.LogNormal(jnp.log(typical), log_sd).expand([P]).to_event(1)


def _whiten(fits, scale) -> tuple[np.ndarray, np.ndarray]:
    """Scaled means and the inverse Cholesky factors of the scaled covariances."""
    m = np.array([f.mean / scale for f in fits])
    W = []
    for f in fits:
        cov = f.cov / np.outer(scale, scale)
        cov = cov + np.eye(len(scale)) * 1e-12 * np.trace(cov)
        W.append(np.linalg.inv(np.linalg.cholesky(cov)))
    return m, np.array(W)


#: A muscle's parameter is sampled centred when its own fit's relative sd is below this: well
#: under the smallest scatter a population shows (F0's own sd of ~3 % beside a scatter of ~5 %
#: mixed poorly centred: R-hat 1.08).
CENTRED_BELOW = 0.02


def _centring(fits, scale) -> np.ndarray:
    """1 where a muscle's own fit pins the (log-)parameter well, else 0."""
    m = np.array([f.mean / scale for f in fits])
    sd = np.array([f.sd / scale for f in fits])
    rel = np.where(_ADDITIVE, sd, sd / np.maximum(np.abs(m), 1e-12))
    return (rel < CENTRED_BELOW).astype(float)


def _init(m, k, F, Off, expected) -> dict[str, np.ndarray]:
    y = np.where(_ADDITIVE, m, np.log(np.maximum(m, 1e-3)))
    intercept = (np.where(_ADDITIVE, np.log(np.maximum(m, 1e-2)), y) - F @ expected.T - Off).mean(0)
    scatter = np.full(m.shape[1], 0.1)
    law = intercept + F @ expected.T + Off
    loc = np.where(_ADDITIVE, np.exp(law), law)
    y_k = np.where(k > 0, y, (y - loc) / scatter)
    return {"intercept": intercept, "exponent": expected, "scatter": scatter, "y_k": y_k}


class Engine:
    """One NUTS sampler, compiled once for its data's shapes and reused (leave-one-out refits
    the same model on as many muscles each time: only the first fold compiles)."""

    def __init__(self, sampler: Sampler = Sampler()) -> None:
        self.sampler = sampler
        self._mcmc: Any = None

    def run(self, args: tuple, init: dict[str, np.ndarray], seed: int):
        import jax
        import jax.numpy as jnp
        from numpyro.infer import MCMC, NUTS

        if self._mcmc is None:
            kernel = NUTS(_model, target_accept_prob=self.sampler.target_accept)
            self._mcmc = MCMC(
                kernel,
                num_warmup=self.sampler.warmup,
                num_samples=self.sampler.draws,
                num_chains=self.sampler.chains,
                chain_method="sequential",
                progress_bar=False,
                jit_model_args=True,
            )
        # ``init``: the start, in the sampler's unconstrained space, for every chain
        start = init
        chains = self.sampler.chains
        init_params = (
            {k: jnp.asarray(np.broadcast_to(v, (chains, *np.shape(v)))) for k, v in start.items()}
            if chains > 1
            else start
        )
        self._mcmc.run(jax.random.PRNGKey(seed), *args, init_params=init_params)
        return self._mcmc


def fit_population(
    specs: tuple[MuscleSpec, ...],
    fits: tuple[MuscleFit, ...],
    *,
    priors: Priors = Priors(),
    sampler: Sampler = Sampler(),
    engine: Engine | None = None,
) -> PopulationFit:
    """Sample the population's posterior from the muscles' builds and their own fits
    (``engine``: a sampler compiled before for as many muscles, else a new one)."""
    import arviz as az

    if len(specs) != len(fits) or not fits:
        raise HmidError(f"need one fit per muscle: {len(specs)} builds, {len(fits)} fits")
    start, cpu = time.perf_counter(), time.process_time()
    names = tuple(f.name for f in fits)
    data = _design(specs, fits)
    engine = engine if engine is not None else Engine(sampler)
    samples, idata = _sample(engine, data, fits, priors, names)
    diagnostics = az.summary(idata, var_names=["intercept", "exponent", "scatter"], hdi_prob=0.9)
    y = samples["y"]
    muscles = np.where(_ADDITIVE, y, np.exp(y)) * data.scale
    return PopulationFit(
        names=names,
        specs=tuple(specs),
        scale=data.scale,
        center=data.center,
        center_offsets=data.center_offsets,
        intercept=samples["intercept"],
        exponent=samples["exponent"],
        scatter=samples["scatter"],
        muscles=muscles,
        diagnostics=diagnostics,
        wall_s=time.perf_counter() - start,
        cpu_s=time.process_time() - cpu,
        idata=idata,
    )


@dataclass(frozen=True)
class _Design:
    """The model's data: features and offsets centred on the population's mean, each muscle's
    own fit scaled by ``scale`` and whitened (see the module docstring)."""

    scale: np.ndarray  # (P,)
    center: np.ndarray  # (F,)
    center_offsets: np.ndarray  # (P,)
    F: np.ndarray  # (n, F) centred features
    Off: np.ndarray  # (n, P) centred offsets
    m: np.ndarray  # (n, P) scaled means
    W: np.ndarray  # (n, P, P) inverse Cholesky factors of the scaled covariances


def _design(specs: tuple[MuscleSpec, ...], fits: tuple[MuscleFit, ...]) -> _Design:
    scale = _scale(fits)
    F_raw = feature_matrix(specs)
    O_raw = np.array([offsets(s) for s in specs])
    center, center_offsets = F_raw.mean(axis=0), O_raw.mean(axis=0)
    m, W = _whiten(fits, scale)
    return _Design(scale, center, center_offsets, F_raw - center, O_raw - center_offsets, m, W)


def _sample(
    engine: Engine,
    data: _Design,
    fits: tuple[MuscleFit, ...],
    priors: Priors,
    names: tuple[str, ...],
) -> tuple[dict[str, np.ndarray], Any]:
    """NUTS draws of every coordinate, and the ArviZ posterior (in 64-bit JAX)."""
    import jax
    import jax.numpy as jnp
    from numpyro.distributions.transforms import biject_to

    expected = expected_matrix()
    with jax.enable_x64(True):
        k = _centring(fits, data.scale)
        args = (
            data.F,
            data.Off,
            data.W,
            data.m,
            k,
            expected,
            _ADDITIVE,
            priors.exponent_sd,
            priors.intercept_sd,
            (priors.scatter_typical, priors.scatter_log_sd),
        )
        init = _init(data.m, k, data.F, data.Off, expected)
        # the scatter's start in the sampler's unconstrained space (its prior's support)
        support = biject_to(_scatter_prior(*args[-1], data.m.shape[1]).support)
        init["scatter"] = np.asarray(support.inv(jnp.asarray(init["scatter"])))
        mcmc = engine.run(args, init, engine.sampler.seed)
        samples = {k: np.asarray(v) for k, v in mcmc.get_samples().items()}
        idata = _inference_data(mcmc, names)
    return samples, idata


def _inference_data(mcmc, names: tuple[str, ...]):
    """The sampler's run as ArviZ InferenceData, its coordinates named."""
    import arviz as az

    return az.from_numpyro(
        mcmc,
        coords={
            "parameter": list(PARAMETERS),
            "feature": list(FEATURES),
            "muscle": list(names),
        },
        dims={
            "intercept": ["parameter"],
            "exponent": ["parameter", "feature"],
            "scatter": ["parameter"],
            "y": ["muscle", "parameter"],
            "y_k": ["muscle", "parameter"],
        },
    )
