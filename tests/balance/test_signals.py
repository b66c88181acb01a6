"""What a value computed from signals read, so that it is reused only where that is unchanged."""

import numpy as np
from _balance_data import signals_with

from hmid.balance.signals import recording


def test_a_cached_derived_value_still_reports_what_it_read():
    signals = signals_with()
    with recording() as first:
        once = signals.derived(("double x",), lambda: 2 * signals["x"])
    with recording() as again:  # a cache hit reads nothing, yet depends on x
        twice = signals.derived(("double x",), lambda: 2 * signals["x"])
    assert once is twice
    assert ("x", signals.versions["x"]) in first and first == again


def test_a_derived_set_keeps_the_versions_of_the_columns_it_keeps():
    signals = signals_with()
    with recording() as deps:
        signals["x"], signals["P"]
    scaled = signals.with_columns(P=2 * signals["P"])
    assert scaled.versions["x"] == signals.versions["x"]
    assert scaled.versions["P"] != signals.versions["P"]
    assert signals.reads_same(deps) and not scaled.reads_same(deps)
    assert scaled.with_columns().reads_same({("x", signals.versions["x"])})
    with recording() as absent:
        assert "nothing" not in signals
    assert signals.reads_same(absent) and not signals.with_columns(
        nothing=np.ones(len(signals))
    ).reads_same(absent)


def test_nested_recordings_each_see_every_read():
    signals = signals_with()
    with recording() as outer:
        with recording() as inner:
            signals.role_frame("train", ("x",))
    assert inner == outer and ("x", signals.versions["x"]) in inner


def test_what_is_cached_in_a_scope_is_dropped_after_it():
    signals = signals_with()
    signals.derived(("kept",), lambda: 1)
    signals.cache["list"] = [1]
    with signals.scoped():
        signals.derived(("dropped",), lambda: 2)
        signals.cache["list"].append(2)
        assert ("dropped",) in signals.cache
    assert ("kept",) in signals.cache and ("dropped",) not in signals.cache
    assert signals.cache["list"] == [1]


def test_new_columns_are_held_once_and_the_set_they_came_from_is_unchanged():
    signals = signals_with()
    column = 2 * signals["P"]
    doubled = signals.with_columns(P=column)
    assert np.shares_memory(doubled["P"], column)  # taken as given: a long log's column once
    np.testing.assert_array_equal(signals["P"] * 2, doubled["P"])
    assert not np.shares_memory(signals["P"], column)
