"""The outcome of an MCMC run (:func:`hmid.models.sls.sampler.run_sampler`): draws, chain,
diagnostics, and summaries of the posterior."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hmid.errors import ConfigError


@dataclass(frozen=True, eq=False)
class SamplerResult:
    """A finished (or budget-stopped) run of :func:`~hmid.models.sls.sampler.run_sampler`.

    ``chain`` (draws, D) and ``log_prob`` (draws,) are the flat posterior draws after
    ``burn_in`` steps and thinning by ``thin``; ``walkers`` (n_steps, n_walkers, D) and
    ``walkers_log_prob`` the whole chain for trace plots. ``tau`` and ``ess`` are per parameter;
    ``tau_history`` rows are ``(iteration, tau_1..tau_D)`` at each convergence check.
    ``wall_s`` is this call's wall time; ``stop_reason`` one of the sampler's ``STOP_REASONS``.
    ``reused_steps`` counts the steps read from a stored chain (0 when sampled afresh): the
    numbers are the same either way, the report says which.
    """

    names: tuple[str, ...]
    chain: np.ndarray
    log_prob: np.ndarray
    acceptance: np.ndarray
    tau: np.ndarray
    ess: np.ndarray
    n_steps: int
    burn_in: int
    thin: int
    stop_reason: str
    wall_s: float
    backend_path: Path | None
    walkers: np.ndarray
    walkers_log_prob: np.ndarray
    tau_history: np.ndarray
    n_nan: int
    reused_steps: int = 0

    @property
    def n_walkers(self) -> int:
        return self.walkers.shape[1]

    @property
    def acceptance_mean(self) -> float:
        return float(np.mean(self.acceptance))

    @property
    def converged(self) -> bool:
        return self.stop_reason in ("converged", "exact")

    def metrics(self) -> dict[str, Any]:
        """Scalar diagnostics for a run manifest."""
        return {
            "stop_reason": self.stop_reason,
            "n_steps": self.n_steps,
            "n_walkers": self.n_walkers,
            "burn_in": self.burn_in,
            "thin": self.thin,
            "n_draws": len(self.chain),
            "acceptance_mean": self.acceptance_mean,
            "tau_max": float(np.max(self.tau)),
            "ess_min": float(np.min(self.ess)),
            "wall_s": self.wall_s,
            "n_nan": self.n_nan,
            "reused_steps": self.reused_steps,
        }

    def summary(
        self,
        units: Mapping[str, str] | None = None,
        confidence: float = 0.90,
        transform: Callable[[np.ndarray], Mapping[str, np.ndarray]] | None = None,
    ) -> pd.DataFrame:
        """Median, equal-tailed credible interval (``lower``, ``upper``), mean, sd and unit.

        ``transform`` maps the draws (draws, D) to physical parameters, name -> (draws,), e.g.
        ``lambda th: {"k": np.exp(th[:, 0]), ...}``; ``units`` must then name those parameters.
        """
        if not 0 < confidence < 1:
            raise ConfigError(f"summary: confidence must lie in (0, 1), got {confidence!r}")
        if transform is None:
            values = {name: self.chain[:, i] for i, name in enumerate(self.names)}
        else:
            values = {name: np.asarray(v, float) for name, v in transform(self.chain).items()}
        missing = [name for name in values if units is not None and name not in units]
        if missing:
            raise ConfigError(f"summary: units has no entry for {', '.join(missing)}")
        tail = (1 - confidence) / 2
        rows = {
            name: {
                "median": float(np.median(v)),
                "lower": float(np.quantile(v, tail)),
                "upper": float(np.quantile(v, 1 - tail)),
                "mean": float(np.mean(v)),
                "sd": float(np.std(v, ddof=1)),
                "unit": "" if units is None else units[name],
            }
            for name, v in values.items()
        }
        return pd.DataFrame.from_dict(rows, orient="index").rename_axis("parameter")

    def draws(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` rows of ``chain`` (without replacement while there are enough) for predictions."""
        index = rng.choice(len(self.chain), size=n, replace=n > len(self.chain))
        return self.chain[index]
