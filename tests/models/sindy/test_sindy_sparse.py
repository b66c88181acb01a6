"""The per-block factors SINDy's bootstrap and cross-validation combine."""

import numpy as np

from hmid.models.sindy._sparse import block_stats, combine


def test_block_factors_are_numpys_qr_of_each_block():
    rng = np.random.default_rng(0)
    sizes = np.r_[rng.integers(20, 60, 30), 4]  # the last block shorter than the columns
    blocks = np.repeat(np.arange(sizes.size), sizes)
    Z, y = rng.normal(size=(blocks.size, 8)), rng.normal(size=blocks.size)
    stats = block_stats(Z, y, blocks)
    full, start = np.column_stack([Z, y]), 0
    for b, size in enumerate(sizes):
        expected = np.linalg.qr(full[start : start + size], mode="r")
        np.testing.assert_array_equal(stats.r[b, : expected.shape[0]], expected)
        assert not stats.r[b, expected.shape[0] :].any()
        start += size
    np.testing.assert_array_equal(stats.rows, sizes)
    # all blocks together: the factor of the whole problem (up to signs of its rows)
    whole = np.linalg.qr(full, mode="r")
    np.testing.assert_allclose(np.abs(combine(stats, np.ones(sizes.size))), np.abs(whole),
                               atol=1e-10)  # fmt: skip
