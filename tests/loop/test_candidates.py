"""One contract, run over every registered candidate effect: columns at every part of its grid,
signs from the rig's declared friction sign (never from a fit), and what it needs of a rig."""

import numpy as np
import pytest
from _loop_data import make_data

from hmid.loop.candidates import CANDIDATES, ELASTIC, Setting

CHANNELS = ("x", "P", "v", "a")


@pytest.fixture(scope="module")
def signals():
    data, _ = make_data(None)
    return data.with_columns(**{ELASTIC: 3000.0 * data["x"]})


@pytest.mark.parametrize("name", sorted(CANDIDATES))
@pytest.mark.parametrize("friction_sign", [1, -1])
def test_every_candidate_gives_signed_columns_over_its_grid(name, friction_sign, signals):
    cls = CANDIDATES[name]
    setting = Setting(friction_sign, "x", CHANNELS)
    candidate = cls(setting)
    assert candidate == cls(setting) and hash(candidate) == hash(cls(setting))  # shares caches
    assert cls.missing(setting) is None and candidate.title and candidate.physics
    hyper = candidate.hyper
    grid = (hyper.grid[0], hyper.grid[len(hyper.grid) // 2], hyper.grid[-1]) if hyper else (None,)
    for value in grid:
        seen = candidate.transform(signals, value)
        assert len(seen) == len(signals)
        columns = candidate.columns(seen, value)
        assert columns.values.shape[0] == len(signals) and np.isfinite(columns.values).all()
        assert all(columns.units) and set(candidate.positive) <= set(columns.names)
        if candidate.friction:
            # a positive friction parameter is friction against the motion, entering the
            # explained quantity with the rig's declared sign
            direction = np.sign(signals["v"])
            for j, parameter in enumerate(columns.names):
                if parameter in candidate.positive:
                    assert np.sign(np.mean(columns.values[:, j] * direction)) == friction_sign
    if hyper is not None:
        low, high = hyper.edges_identified
        assert candidate.identified(hyper.grid[0]) == low
        assert candidate.identified(hyper.grid[-1]) == high


@pytest.mark.parametrize("name", sorted(CANDIDATES))
def test_a_candidate_says_what_a_rig_lacks_for_it(name):
    cls = CANDIDATES[name]
    bare = Setting(None, "x", ("x", "v", "a"))
    why = cls.missing(bare)
    needs_p, needs_sign = "P" in cls.requires, cls.friction
    assert (why is None) == (not needs_p and not needs_sign), why
    if needs_p:
        assert "['P']" in why
