"""Log pieces: splitting at logger pauses keeps every sample."""

import numpy as np
import pandas as pd

from hmid.io.log import Log
from hmid.io.segments import split_at_gaps


def _log(t):
    frame = pd.DataFrame({"t": t, "x": np.sin(t), "v": np.cos(t), "P": 1e5 + 0 * t, "F": t})
    return Log(frame, "test.csv", {"t": "s", "x": "m", "v": "m/s", "P": "Pa", "F": "N"})


def test_split_at_gaps_keeps_every_sample_in_order():
    parts = [np.arange(0, 1, 0.01), np.arange(1.5, 2, 0.01), np.arange(2.3, 3, 0.01)]
    t = np.concatenate(parts)
    pieces = split_at_gaps(_log(t), 0.1)
    assert [len(p) for p in pieces] == [len(p) for p in parts]
    np.testing.assert_array_equal(np.concatenate([p.t for p in pieces]), t)
