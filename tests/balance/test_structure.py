"""Structures of terms fitted by least squares: profiled parameters found on their grids and
refined, intervals that include them, identical columns entered once."""

import numpy as np
import pytest
from _balance_data import signals_with

from hmid.balance import Structure, fit, make_term, parameters, profile
from hmid.balance.operations import memory_arms

NOISE = 0.01  # N


def _memory_data(tau=0.3, k2=800.0, k1=2000.0, seed=0):
    signals = signals_with()
    g = memory_arms(signals, "x", (tau,))[0]
    noise = np.random.default_rng(seed).normal(0, NOISE, len(signals))
    return signals.with_columns(target=-k1 * signals["x"] - k2 * g + 1.5 + noise)


TERMS = [
    {"kind": "channel", "name": "k1", "channel": "x", "sign": -1, "positive": True},
    {"kind": "memory", "name": "k2", "channel": "x", "sign": -1, "positive": True},
    {"kind": "constant", "name": "F0"},
]


def test_a_relaxation_time_is_profiled_and_every_parameter_covered():
    signals = _memory_data()
    fitted = profile(Structure.of([make_term(t) for t in TERMS]), signals)
    table = parameters(fitted, signals, 0.95)
    table = table.set_index("parameter")
    truth = {"k1": 2000.0, "k2": 800.0, "F0": 1.5, "tau_k2": 0.3}
    for name, value in truth.items():
        assert table.loc[name, "lower"] <= value <= table.loc[name, "upper"], (name, table)
    assert table.loc["tau_k2", "unit"] == "s" and table.loc["k2", "unit"] == "N/m"
    assert np.sqrt(fitted.sse / fitted.fit.n) == pytest.approx(NOISE, rel=0.05)


def test_two_profiled_parameters_are_found_by_coordinate_sweeps():
    signals = signals_with()
    g = memory_arms(signals, "x", (0.15,))[0]
    from hmid.balance.operations import lagged

    delayed = lagged(signals, signals["P"], 0.03, "delay")
    noise = np.random.default_rng(1).normal(0, NOISE, len(signals))
    signals = signals.with_columns(target=2e-4 * delayed - 600.0 * g + noise)
    terms = [
        make_term({"kind": "lag", "name": "A", "channel": "P"}),
        make_term({"kind": "memory", "name": "k2", "channel": "x", "sign": -1}),
    ]
    structure = Structure.of(terms)
    signals = signals.trim(*structure.margins)
    fitted = profile(structure, signals)
    assert fitted.structure.terms[0].value == pytest.approx(0.03, abs=0.0025)
    assert fitted.structure.terms[1].value == pytest.approx(0.15, rel=0.05)
    assert fitted.params["A"] == pytest.approx(2e-4, rel=0.01)


def test_a_column_two_terms_share_enters_once_and_columns_are_cached():
    signals = signals_with(target=None)
    a = make_term({"kind": "coulomb", "name": "Fc"})
    b = make_term({"kind": "coulomb", "name": "Fc2"})  # the same column under another name
    structure = Structure.of([a, b])
    columns = structure.columns(signals)
    assert columns.names == ("Fc",)
    assert structure.columns(signals).values is not None
    assert ("columns", a, None, id(signals)) in signals.cache
    assert fit(structure, signals).columns.width == 1
