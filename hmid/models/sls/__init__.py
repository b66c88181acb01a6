"""Bayesian Standard Linear Solid muscle model: exact JAX recursion, optimistix start, emcee."""

from hmid.models.sls._data import SLSData, sls_data
from hmid.models.sls._space import SLSSpace
from hmid.models.sls.model import SLSModel
from hmid.models.sls.sampler import SamplerConfig, SamplerError, SamplerResult, run_sampler
from hmid.models.sls.start import StartError, StartResult, initial_fit

__all__ = [
    "SLSData",
    "SLSModel",
    "SLSSpace",
    "SamplerConfig",
    "SamplerError",
    "SamplerResult",
    "StartError",
    "StartResult",
    "initial_fit",
    "run_sampler",
    "sls_data",
]
