"""Held-out rows are only held-out rows; the metrics match their definitions."""

import numpy as np
import pytest

from hmid.errors import ConfigError
from hmid.metrics import score
from hmid.split import SplitSpec, validation_masks


def test_time_block_holds_out_the_last_fraction_of_each_log():
    masks = validation_masks({"a": 100, "b": 10}, SplitSpec(validation_fraction=0.3))
    assert masks["a"].sum() == 30 and masks["a"][70:].all() and not masks["a"][:70].any()
    assert masks["b"].sum() == 3 and masks["b"][7:].all()


def test_log_split_holds_out_whole_logs():
    masks = validation_masks({"a": 5, "b": 4}, SplitSpec(kind="logs", validation_logs=("b",)))
    assert not masks["a"].any() and masks["b"].all()


@pytest.mark.parametrize(
    ("spec", "lengths", "match"),
    [
        (SplitSpec(kind="logs", validation_logs=("zz",)), {"a": 3, "b": 3}, "zz"),
        (SplitSpec(kind="logs", validation_logs=("a",)), {"a": 3}, "nothing left"),
    ],
)
def test_bad_log_splits_are_config_errors(spec, lengths, match):
    with pytest.raises(ConfigError, match=match):
        validation_masks(lengths, spec)


def test_split_spec_validation():
    with pytest.raises(ValueError, match="needs validation_logs"):
        SplitSpec(kind="logs")
    with pytest.raises(ValueError, match="greater than 0"):
        SplitSpec(validation_fraction=0.0)


def test_scores_match_their_definitions():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    y_hat = np.array([1.1, 1.9, 3.2, 3.8])
    s = score(y, y_hat)
    err = y - y_hat
    assert s.rmse == pytest.approx(np.sqrt(np.mean(err**2)))
    assert s.r2 == pytest.approx(1 - np.sum(err**2) / np.sum((y - 2.5) ** 2))
    assert s.max_abs_error == pytest.approx(0.2)
    assert s.error_variance == pytest.approx(np.var(err, ddof=1))
    fit = 100 * (1 - np.linalg.norm(err) / np.linalg.norm(y - 2.5))
    assert s.nrmse_fit_pct == pytest.approx(fit)
    perfect = score(y, y)
    assert perfect.r2 == 1.0 and perfect.nrmse_fit_pct == 100.0 and perfect.rmse == 0.0
