"""LoopData: masks, segment ends, building from log pieces."""

import numpy as np
import pandas as pd
import pytest
from conftest import make_data

from hmid.io.log import Log
from hmid.io.segments import split_at_gaps
from hmid.loop.data import LoopData, from_segments


def test_trimming_segment_ends_only_changes_masks():
    data, _ = make_data(None)
    trimmed = data.trim_segment_ends(0.5)
    assert len(trimmed) == len(data)
    np.testing.assert_array_equal(trimmed["y"], data["y"])
    for rows in trimmed.segments():
        t = trimmed["t"][rows]
        late = t > t[-1] - 0.5
        assert not trimmed.train[rows][late].any() and not trimmed.validation[rows][late].any()


def test_a_row_cannot_be_both_trained_on_and_held_out():
    data, _ = make_data(None)
    with pytest.raises(ValueError, match="both"):
        LoopData(data.frame.assign(train=True, validation=True))


def _log(t):
    frame = pd.DataFrame({"t": t, "x": np.sin(t), "v": np.cos(t), "P": 1e5 + 0 * t, "F": t})
    return Log(frame, "test.csv", {"t": "s", "x": "m", "v": "m/s", "P": "Pa", "F": "N"})


def test_split_at_gaps_keeps_every_sample_in_order():
    parts = [np.arange(0, 1, 0.01), np.arange(1.5, 2, 0.01), np.arange(2.3, 3, 0.01)]
    t = np.concatenate(parts)
    pieces = split_at_gaps(_log(t), 0.1)
    assert [len(p) for p in pieces] == [len(p) for p in parts]
    np.testing.assert_array_equal(np.concatenate([p.t for p in pieces]), t)


def test_from_segments_holds_out_whole_logs_and_trims_piece_ends():
    t = np.arange(0, 2, 0.01)
    segments = {"a": [_log(t), _log(t + 3)], "b": [_log(t)]}
    data = from_segments(segments, target="F", validation={"b"}, v_deadband=0.0, reach=5)
    frame = data.frame
    assert set(frame.loc[frame["validation"], "log"]) == {"b"}
    assert set(frame.loc[frame["train"], "log"]) == {"a"}
    assert frame["segment"].nunique() == 3
    for rows in data.segments():
        used = data.train[rows] | data.validation[rows]
        assert not used[:5].any() and not used[-5:].any() and used[5:-5].all()
