"""Blocked cross-validation and its bootstrap: every training row predicted once by a fit that
never saw its block, and a bootstrap bound that says "better" only when the blocks agree."""

import numpy as np
from _loop_data import make_data

from hmid.balance import Columns, Structure
from hmid.balance.kinds import make_term
from hmid.loop.selection import Folds, change, out_of_fold
from hmid.stats import block_resamples


def test_folds_hold_every_training_row_once_in_blocks_within_segments():
    signals, _ = make_data(None)
    folds = Folds.of(signals, folds=5, block_s=1.0)
    train = signals.train
    assert (folds.block >= 0).sum() == train.sum() and not (folds.block[~train] >= 0).any()
    assert sum(folds.rows(k).sum() for k in range(5)) == train.sum()
    segment = signals.frame["segment"].to_numpy()
    for b in range(folds.blocks):  # a block never spans two segments, nor more than 1 s
        rows = folds.block == b
        assert len(np.unique(segment[rows])) == 1 and np.ptp(signals["t"][rows]) < 1.0


def test_out_of_fold_residuals_come_from_fits_that_did_not_see_the_row():
    signals, _ = make_data(None)
    folds = Folds.of(signals, folds=5, block_s=1.0)
    # an offset on one fold's rows: fitted in-sample it is shared by all, out of fold it is not
    shifted = np.random.default_rng(2).normal(0.0, 0.01, len(signals))
    shifted[folds.rows(0)] += 1.0
    data = signals.with_columns(target=shifted)
    constant = Structure.of([make_term({"kind": "constant", "name": "F0"})])
    residual = out_of_fold(constant, data, folds)
    assert np.isnan(residual[~signals.train]).all()
    held, rest = folds.rows(0), folds.rows(1)
    # fold 0 is fitted by the others (mean ~0): its offset is all residual; fold 1's fit saw
    # fold 0 among four, so its mean is ~1/4 too high
    assert np.mean(residual[held]) > 0.95 and abs(np.mean(residual[rest]) + 0.25) < 0.05


def test_the_bootstrap_bound_says_better_only_when_the_blocks_agree():
    signals, _ = make_data(None)
    folds = Folds.of(signals, folds=5, block_s=1.0)
    counts = block_resamples(400, folds.blocks, seed=1)
    rng = np.random.default_rng(0)
    before = np.where(signals.train, rng.normal(0, 1.0, len(signals)), np.nan)
    same = change(before, before, folds, counts, 0.95)
    assert same.change == same.upper == same.lower == 0.0 and not same.better(0.0)
    halved = change(before, before / 2, folds, counts, 0.95)
    assert np.isclose(halved.change, -0.5) and halved.better(0.4) and not halved.better(0.6)
    # better in half the blocks, worse in the rest: no confident improvement
    mixed = before.copy()
    first = np.isin(folds.block, np.arange(0, folds.blocks, 2))
    mixed[first] *= 0.5
    mixed[~first & signals.train] *= 1.3
    assert not change(before, mixed, folds, counts, 0.95).better(0.0)
    np.testing.assert_array_equal(counts, block_resamples(400, folds.blocks, seed=1))  # seeded


def test_a_refining_term_takes_the_place_of_the_columns_its_span_holds():
    n, rows = 200, np.arange(200)
    v = np.sin(np.linspace(0, 6, n))
    one = Columns(("b",), ("N s/m",), v[:, None])
    split = Columns(("b_pos", "b_neg"), ("N s/m",) * 2, np.column_stack([v * (v > 0), v * (v < 0)]))
    level = Columns(("F0",), ("N",), np.ones((n, 1)))
    merged = Columns.combine(n, [("a", one, False), ("c", level, False), ("s", split, True)], rows)
    assert merged.names == ("F0", "b_pos", "b_neg")
    kept = Columns.combine(n, [("a", one, False), ("s", split, False)], rows)
    assert kept.names == ("b", "b_pos", "b_neg")  # without refining, both stay
