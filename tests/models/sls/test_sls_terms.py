"""The SLS force declared once (hmid.models.sls.terms): every reader sees the same force."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hmid.families.sls import SLSSpec
from hmid.models.sls import SLSModel, SLSSpace, sls_data
from hmid.models.sls.terms import SLSForce
from hmid.signal.maxwell import responses

CONFIGS = [("cubic", 1), ("linear", 1), ("cubic", 2), ("linear", 3)]


def _data(n=400, seed=0):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.5e-3, 2e-3, n))
    x = 0.006 + 0.003 * np.sin(2 * np.pi * 3.1 * t)
    P = 1.4e5 + 8e4 * np.sin(2 * np.pi * 2.3 * t)
    return sls_data([pd.DataFrame({"t": t, "x": x, "P": P, "F": np.zeros(n), "use": True})])


@pytest.mark.parametrize(("spring", "arms"), CONFIGS)
def test_the_columns_times_beta_are_the_likelihoods_mean_force(spring, arms):
    force = SLSForce(spring, arms)
    model = SLSModel(spring, arms)
    taus = np.geomspace(0.02, 0.5, arms)
    physical = {"A_eff": 2e-4, "F0": 1.5, "k1": 3e3, "k3": 1e6}
    for i, (k2, tau) in enumerate(force.arm_names()):
        physical |= {k2: 800.0 * (i + 1), tau: float(taus[i])}
    data = _data()
    g = responses(data.t, data.x, data.start, taus)
    columns = [*force.fixed_columns(data.P, data.x, data.x3), *(-g.T)]
    beta = [physical[p.name] for p in force.linear]
    assert len(columns) == force.n_linear == len(beta)
    mean = model.predict({k: v for k, v in physical.items() if k in model.space.physical_names},
                         data)  # fmt: skip
    np.testing.assert_allclose(np.column_stack(columns) @ beta, mean, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize(("spring", "arms"), CONFIGS)
def test_names_terms_and_sizes_come_from_the_declaration(spring, arms):
    force = SLSForce(spring, arms)
    space = SLSSpace(spring, arms, "ar1")
    names = [p.name for p in force.linear]
    assert [n for n in space.physical_names if not n.startswith(("tau", "sigma", "phi"))] == names
    terms = force.terms(position="z", pressure="Pm", sign=-1)
    assert [t.name for t in terms] == names
    assert [t.sign for t in terms] == [-p.sign for p in force.linear]
    assert [t.positive for t in terms] == [p.positive for p in force.linear]
    assert [getattr(t, "channel", None) for t in terms][: force.n_fixed] == [
        {"P": "Pm", "1": None, "x": "z", "x^3": "z^3"}[p.regressor] for p in force.fixed
    ]
    assert SLSSpec(spring=spring, arms=arms, noise="ar1").dimension == space.dim
    assert SLSSpec(spring=spring, arms=arms).dimension == SLSSpace(spring, arms).dim
