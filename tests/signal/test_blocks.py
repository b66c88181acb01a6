"""A signal smoothed block by block is the signal smoothed whole."""

import numpy as np
import pytest

from hmid.signal import Identity, MovingAverage, Window
from hmid.signal.blocks import local_smoother, smoothed_by_blocks, smoothed_span

SMOOTHERS = (
    MovingAverage(Window(seconds=0.011)),
    MovingAverage(Window(seconds=0.011), passes=3),
    MovingAverage(10, mode="causal"),
    MovingAverage(9, edge="nan"),
    MovingAverage(9, edge="reflect"),
    Identity(),
)


@pytest.mark.parametrize("smoother", SMOOTHERS, ids=repr)
@pytest.mark.parametrize("block", [1, 7, 97, 5000])
def test_blocks_of_any_size_give_the_whole_smoothed_signal(smoother, block):
    rng = np.random.default_rng(block)
    t = np.cumsum(rng.uniform(0.9e-3, 1.1e-3, 2003))  # jittered: the window is t's, not a block's
    values = np.cumsum(rng.normal(size=t.size))
    whole = smoother(t, values)
    local = local_smoother(smoother, t)
    got = smoothed_by_blocks(local, t.size, values.__getitem__, block)
    np.testing.assert_allclose(got, whole, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        smoothed_span(local, t.size, values.__getitem__, 1000, 1010), whole[1000:1010], rtol=1e-12
    )


def test_a_stretch_cut_without_its_margin_is_not_the_whole():
    t = np.arange(2000) * 1e-3
    values = np.cumsum(np.random.default_rng(0).normal(size=t.size))
    margin, smooth = MovingAverage(Window(seconds=0.011)).local(t)
    whole = MovingAverage(Window(seconds=0.011))(t, values)
    assert margin >= 11
    assert not np.allclose(smooth(values[500:600])[:3], whole[500:503])
    inner = smooth(values[500 - margin : 600 + margin])[margin:-margin]
    np.testing.assert_allclose(inner, whole[500:600], rtol=1e-12)
