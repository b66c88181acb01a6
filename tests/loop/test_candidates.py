"""One contract, run over the whole library a rich rig is offered: columns at every part of
each grid, signs from the rig's declared friction sign (never from a fit), units, and what each
candidate needs of a rig; then how the library is generated for other rigs."""

import numpy as np
import pytest
from _loop_data import make_data

from hmid.loop.candidates import ELASTIC, STIFFNESS, Setting, library, make_candidates

CHANNELS = ("x", "P", "v", "a")
RICH = Setting(-1, "x", CHANNELS)
NAMES = sorted(library(RICH))


@pytest.fixture(scope="module")
def signals():
    data, _ = make_data(None)
    return data.with_columns(**{ELASTIC: 3000.0 * data["x"], STIFFNESS: np.full(len(data), 3e3)})


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("friction_sign", [1, -1])
def test_every_candidate_gives_signed_columns_over_its_grid(name, friction_sign, signals):
    setting = Setting(friction_sign, "x", CHANNELS)
    candidate = library(setting)[name]
    again = library(setting)[name]
    assert candidate == again and hash(candidate) == hash(again)  # equal ones share caches
    assert candidate.title and candidate.physics and candidate.follows
    assert set(candidate.requires) <= set(CHANNELS)
    hyper = candidate.hyper
    grid = (hyper.grid[0], hyper.grid[len(hyper.grid) // 2], hyper.grid[-1]) if hyper else (None,)
    for value in grid:
        seen = candidate.transform(signals, value)
        assert len(seen) == len(signals)
        columns = candidate.columns(seen, value)
        assert columns.values.shape[0] == len(signals) and np.isfinite(columns.values).all()
        assert all(columns.units) and set(candidate.positive) <= set(columns.names)
        assert columns.width or hyper is not None  # an effect adds columns or changes signals
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


def test_the_library_is_generated_from_the_rigs_channels():
    names = set(library(Setting(1, "q", ("q", "v", "a", "u"))))
    # a rig with position q and an input u: friction modulated by both, timing on both
    assert {"coulomb.q", "coulomb.u", "viscous.u", "delay.q", "delay.u", "lag.u"} <= names
    assert not any(n.endswith((".P", ".x")) for n in names)
    # a direction-dependent Coulomb level is not identifiable against a free offset
    assert "coulomb.direction" not in names and "viscous.direction" in names
    # no friction sign (none declared, no damper or mass in the balance): no friction
    # candidate; no position: no elastic or motion ones
    assert not any(n.split(".")[0] in ("coulomb", "viscous", "stribeck")
                   for n in library(Setting(None, "x", ("x", "v", "a"))))  # fmt: skip
    assert set(library(Setting(None, None, ("u",)))) == {"zero_drift", "delay.u", "lag.u"}


def test_special_cases_are_refinements_not_rivals():
    lib = library(RICH)
    assert lib["viscous"].special_case_of(lib["viscous.direction"])
    assert "coulomb" not in lib  # the level's change is refitted in the loop's base
    assert not lib["viscous.direction"].special_case_of(lib["viscous"])
    assert not lib["coulomb.x"].special_case_of(lib["coulomb.P"])
    assert not lib["delay.x"].special_case_of(lib["lag.x"])


def test_an_effect_the_rig_cannot_show_is_a_one_line_error():
    with pytest.raises(Exception, match=r"delay\.P.*offers"):
        make_candidates(["delay.P"], Setting(1, "x", ("x", "v", "a")))


def test_every_friction_coefficient_must_oppose_the_motion_each_direction_too():
    offered = library(RICH)
    one_sided = offered["stribeck.direction"]
    # a seal's alternative with delta_neg = -13.8 [-15.7, -11.9] N is no friction
    assert not one_sided.signs_hold({"delta_pos": 4.0, "delta_neg": -11.9})
    assert one_sided.signs_hold({"delta_pos": 4.0, "delta_neg": 0.3})  # zero within reach
    assert not offered["viscous.direction"].signs_hold({"b_pos": 2.0, "b_neg": -0.5})


def test_timing_grids_follow_the_sample_rate():
    from hmid.loop.candidates.timing import DELAYS, delays

    assert delays(None) == DELAYS == delays(0.005)  # 200 Hz: 2.5 ms steps are finer
    fast = delays(0.001)  # 1 kHz: a 0.6 ms delay needs values that bracket it
    assert fast[1] == 0.001 and fast[-1] == DELAYS[-1] and len(fast) == 101
