"""One muscle's identification as the population reads it: its posterior, as a likelihood.

The SLS family's exact posterior has a flat prior on A_eff, F0, k1, k3 and k2 (integrated out)
and tau on a grid, so it is the muscle's likelihood up to a constant. Its draws (the model file's
ArviZ posterior) are summarised by their mean and covariance in the physical parameters: the
linear coefficients are Gaussian given tau, and a weakly determined one (k3 of a long muscle, whose
cubic term hardly shows in 15 mm) keeps its wide, even sign-crossing, spread rather than being
forced onto a log scale it does not reach.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hmid.errors import HmidError
from hmid.population._law import PARAMETERS


@dataclass(frozen=True)
class MuscleFit:
    """One muscle's posterior summary: mean and covariance of PARAMETERS, and the draws' count."""

    name: str
    mean: np.ndarray  # (6,)
    cov: np.ndarray  # (6, 6)
    draws: int

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(np.diag(self.cov))


def summarise(name: str, draws: np.ndarray) -> MuscleFit:
    """A muscle's summary from posterior draws (rows) of PARAMETERS (columns)."""
    draws = np.asarray(draws, dtype=float)
    if draws.ndim != 2 or draws.shape[1] != len(PARAMETERS) or len(draws) < 10:
        raise HmidError(f"muscle {name}: need draws x {len(PARAMETERS)} posterior draws")
    if not np.all(np.isfinite(draws)):
        raise HmidError(f"muscle {name}: its posterior draws are not all finite")
    return MuscleFit(name, draws.mean(axis=0), np.cov(draws, rowvar=False), len(draws))


def from_run(name: str, run: Path, model: str = "sls") -> MuscleFit:
    """The summary of the SLS model that the run folder ``run`` exported."""
    from hmid.portable import load_model

    path = Path(run) / "models" / f"{model}.json"
    if not path.exists():
        raise HmidError(f"muscle {name}: {path} missing (did its SLS fit fail?)")
    posterior = load_model(path).posterior
    if posterior is None:
        raise HmidError(f"muscle {name}: the model {path} has no posterior draws")
    post = posterior.posterior
    draws = np.column_stack([np.asarray(post[p]).reshape(-1) for p in PARAMETERS])
    return summarise(name, draws)
