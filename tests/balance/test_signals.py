"""What a value computed from signals read, so that it is reused only where that is unchanged;
the memo that keeps such values, outside the signals."""

import gc
import pickle

import numpy as np
import pytest
from _balance_data import signals_with

from hmid.balance.memo import Memo


def test_a_cached_derived_value_still_reports_what_it_read():
    signals = signals_with()
    with signals.memo.recording() as first:
        once = signals.derived(("double x",), lambda: 2 * signals["x"])
    with signals.memo.recording() as again:  # a cache hit reads nothing, yet depends on x
        twice = signals.derived(("double x",), lambda: 2 * signals["x"])
    assert once is twice
    assert ("x", signals.versions["x"]) in first and first == again


def test_a_derived_set_keeps_the_versions_of_the_columns_it_keeps():
    signals = signals_with()
    with signals.memo.recording() as deps:
        signals["x"], signals["P"]
    scaled = signals.with_columns(P=2 * signals["P"])
    assert scaled.versions["x"] == signals.versions["x"]
    assert scaled.versions["P"] != signals.versions["P"]
    assert signals.reads_same(deps) and not scaled.reads_same(deps)
    assert scaled.with_columns().reads_same({("x", signals.versions["x"])})
    with signals.memo.recording() as absent:
        assert "nothing" not in signals
    assert signals.reads_same(absent) and not signals.with_columns(
        nothing=np.ones(len(signals))
    ).reads_same(absent)


def test_nested_recordings_each_see_every_read():
    signals = signals_with()
    with signals.memo.recording() as outer:
        with signals.memo.recording() as inner:
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


def test_a_derived_set_shares_its_memo_and_a_dropped_set_leaves_nothing_in_it():
    signals = signals_with()
    doubled = signals.with_columns(P=2 * signals["P"])
    assert doubled.memo is signals.memo
    x = doubled["x"]
    doubled.derived(("x2",), lambda: 2 * x)
    stores = len(signals.memo)
    del doubled
    gc.collect()
    assert len(signals.memo) == stores - 1


def test_a_set_with_new_roles_keeps_its_time_base_and_one_with_new_times_finds_it_again():
    """A long log's segments and smoothers are found once (its median time step is a
    difference of the whole time column): kept by a set that keeps t and the segments."""
    signals = signals_with()
    bounds = signals.bounds()
    smoothers = signals.derived(("local smoothers",), lambda: [signals["t"][:3]])
    kept = signals.with_roles(signals.train, ~signals.train)
    assert kept.bounds() is bounds
    assert kept.derived(("local smoothers",), lambda: pytest.fail("found again")) is smoothers
    later = signals.with_columns(t=signals["t"] + 1.0)
    assert later.derived(("local smoothers",), lambda: "again") == "again"
    assert later.bounds() is bounds  # the segments' rows read the segments alone


def test_a_pickled_set_starts_a_new_memo_and_a_memo_never_pickles():
    signals = signals_with()
    signals.derived(("kept",), lambda: 1)
    loaded = pickle.loads(pickle.dumps(signals))
    assert loaded.memo is not signals.memo and ("kept",) not in loaded.cache
    assert list(loaded.versions) == list(signals.versions)
    with pytest.raises(TypeError, match="pickle the signals"):
        pickle.dumps(Memo())


def test_new_columns_are_held_once_and_the_set_they_came_from_is_unchanged():
    signals = signals_with()
    column = 2 * signals["P"]
    doubled = signals.with_columns(P=column)
    assert np.shares_memory(doubled["P"], column)  # taken as given: a long log's column once
    np.testing.assert_array_equal(signals["P"] * 2, doubled["P"])
    assert not np.shares_memory(signals["P"], column)


def test_smoothing_at_some_rows_is_smoothing_the_whole_there():
    import pandas as pd

    from hmid.balance.signals import Signals
    from hmid.signal import MovingAverage, Window

    rng = np.random.default_rng(3)
    lengths = (5000, 37, 2600)  # a segment shorter than the margin is smoothed whole
    t = np.concatenate([np.arange(n) * 1e-3 * (1 + 0.1 * k) for k, n in enumerate(lengths)])
    frame = pd.DataFrame(
        {
            "log": np.repeat(["a", "a", "b"], lengths),
            "segment": np.repeat([0, 1, 2], lengths),
            "t": t,
            "x": rng.normal(size=t.size),
            "target": np.zeros(t.size),
        }
    )
    values = np.cumsum(rng.normal(size=t.size))
    rows = np.sort(rng.choice(t.size, 3000, replace=False))
    # each segment on its own time base; every kind of edge is tested in tests/signal
    for smoother in (MovingAverage(Window(seconds=0.011), passes=3), MovingAverage(9), None):
        signals = Signals.from_frame(frame, {"x": "m", "target": "N"}, smoother=smoother)
        whole = signals.smooth(values)
        by_blocks = signals.smooth_of(values.__getitem__)
        np.testing.assert_allclose(by_blocks, whole, rtol=1e-12, atol=1e-12, err_msg=str(smoother))
        for pick in (rows, rows[100:400], rows[-5:], np.arange(4990, 5050), np.arange(3)):
            at = signals.smooth_at(values.__getitem__, pick)
            np.testing.assert_allclose(
                at, whole[pick], rtol=1e-12, atol=1e-12, err_msg=str(smoother)
            )
    # the check can fail: smoothed without its margin, a stretch differs from the whole there
    cut = MovingAverage(Window(seconds=0.011)).on(t[100:200])(values[100:200])
    assert not np.allclose(
        cut[:3], MovingAverage(Window(seconds=0.011))(t[:5000], values[:5000])[100:103]
    )
