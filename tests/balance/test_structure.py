"""Structures of terms fitted by least squares: profiled parameters found on their grids and
refined, intervals that include them, identical columns entered once."""

import numpy as np
import pytest
from _balance_data import signals_with

from hmid.balance import Structure, estimated, fit_structure, make_term, parameters, profile
from hmid.balance.columns import Columns
from hmid.balance.inference import sandwich
from hmid.balance.operations import memory_arms
from hmid.balance.terms import Term

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


def test_the_coefficients_covariance_is_the_one_the_intervals_read():
    """What a model file carries for draws of the coefficients: the standard errors of the
    table on its diagonal, and the profiled relaxation time's trade-off with k2 in it."""
    signals = _memory_data()
    fitted = profile(Structure.of([make_term(t) for t in TERMS]), signals)
    table, cov = estimated(fitted, signals, 0.95)
    names = list(fitted.columns.names)
    assert cov.shape == (len(names), len(names)) and np.allclose(cov, cov.T)
    se = table.set_index("parameter").loc[names, "std. error"].to_numpy()
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), se, rtol=1e-12)
    _, fixed = sandwich(fitted.columns, fitted.target, fitted.rows, signals, 0.95)
    k2 = names.index("k2")
    assert cov[k2, k2] > 1.05 * fixed[k2, k2]  # 1.13 here: at a fixed tau_k2, k2 looks surer


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
    assert len(signals.cache[("columns", a, None)]) == 1
    assert fit_structure(structure, signals).columns.width == 1


class _Scaled(Term):
    """A sensor effect: every term sees ``channel`` scaled by 1.01."""

    def __init__(self, channel: str) -> None:
        self.name, self.channel = f"scaled {channel}", channel

    def columns(self, signals, value):
        return Columns.empty(len(signals))

    def transform(self, signals, value):
        return signals.with_columns(**{self.channel: 1.01 * signals[self.channel]})


def test_a_sensor_effect_recomputes_only_the_columns_that_read_its_channel():
    """Columns are kept per set of the (column, version) pairs they read: a sensor effect on P
    reuses the memory arm of x, one on x recomputes it; each equals a fresh computation."""
    signals = signals_with()
    memory = make_term({"kind": "memory", "name": "k2", "channel": "x", "sign": -1})
    pressure = make_term({"kind": "channel", "name": "A", "channel": "P"})
    Structure.of([memory, pressure], {0: 0.15}).columns(signals)
    for channel, entries in (("P", 1), ("x", 2)):
        structure = Structure.of([_Scaled(channel), memory, pressure], {1: 0.15})
        design = structure.columns(signals)
        assert len(signals.cache[("columns", memory, 0.15)]) == entries
        assert len(signals.cache[("columns", pressure, None)]) == 2  # P as logged, P scaled
        seen = structure.seen(signals)
        fresh = np.column_stack(
            [memory.columns(seen, 0.15).values, pressure.columns(seen, None).values]
        )
        np.testing.assert_array_equal(design.values, fresh)
