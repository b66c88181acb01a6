"""Posterior draws as ArviZ InferenceData: netCDF round trip and ArviZ's diagnostics."""

import arviz as az
import numpy as np

from hmid.portable.posterior import diagnostics, write_posterior


def test_draws_round_trip_through_netcdf(tmp_path):
    rng = np.random.default_rng(0)
    draws = {"k1": rng.normal(3000, 5, (1, 400)), "tau": rng.normal(0.2, 1e-3, (1, 400))}
    path = write_posterior(draws, tmp_path / "m.posterior.nc", {"model": "m"})
    data = az.from_netcdf(path)
    assert np.array_equal(data.posterior["k1"].values, draws["k1"])
    assert data.posterior.attrs["model"] == "m"
    assert not list(tmp_path.glob(".*partial"))  # written through a temporary file


def test_diagnostics_tell_mixed_chains_from_stuck_ones():
    rng = np.random.default_rng(1)
    mixed = rng.normal(size=(4, 1000))
    stuck = mixed + np.arange(4)[:, None]  # each chain in its own place
    table = diagnostics({"mixed": mixed, "stuck": stuck}).set_index("parameter")
    assert abs(table.loc["mixed", "r_hat"] - 1) < 0.01
    assert table.loc["stuck", "r_hat"] > 1.5
    assert table.loc["mixed", "ess_bulk"] > 2500 and table.loc["stuck", "ess_bulk"] < 100


def test_one_chain_has_no_r_hat_but_an_ess():
    table = diagnostics({"a": np.random.default_rng(2).normal(size=(1, 500))})
    assert np.isnan(table["r_hat"].iloc[0]) and table["ess_bulk"].iloc[0] > 300
