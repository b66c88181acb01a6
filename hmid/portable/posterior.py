"""Posterior draws as ArviZ ``InferenceData`` (netCDF), and ArviZ's convergence diagnostics:
rank-normalised split R-hat, bulk and tail effective sample sizes (Vehtari et al. 2021)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd


def inference_data(draws: dict[str, np.ndarray], attrs: dict | None = None):
    """``draws`` (name -> (chains, draws)) as InferenceData with ``attrs`` on its posterior."""
    import arviz as az

    data = az.from_dict(posterior={k: np.asarray(v, dtype=float) for k, v in draws.items()})
    data.posterior.attrs.update({k: str(v) for k, v in (attrs or {}).items()})
    return data


def write_posterior(draws: dict[str, np.ndarray], path: Path, attrs: dict | None = None) -> Path:
    """Write the draws to ``path`` (netCDF) through a temporary file renamed into place."""
    path = Path(path)
    partial = path.with_name(f".{path.name}.partial")
    inference_data(draws, attrs).to_netcdf(str(partial))
    os.replace(partial, path)
    return path


def diagnostics(draws: dict[str, np.ndarray]) -> pd.DataFrame:
    """Per parameter: R-hat (rank-normalised, split), bulk and tail ESS; R-hat needs two chains
    or more (NaN otherwise)."""
    import arviz as az

    data = inference_data(draws)
    rows = []
    for name in draws:
        chains = np.asarray(draws[name])
        rhat = float(az.rhat(data, var_names=[name])[name]) if chains.shape[0] > 1 else np.nan
        rows.append({
            "parameter": name,
            "r_hat": rhat,
            "ess_bulk": float(az.ess(data, var_names=[name], method="bulk")[name]),
            "ess_tail": float(az.ess(data, var_names=[name], method="tail")[name]),
        })  # fmt: skip
    return pd.DataFrame(rows)
