"""What an interval is: the calibration status a coefficient table prints."""

import pytest

from hmid.intervals import IntervalNote


def test_the_status_says_whether_the_fit_lies_in_the_calibrated_range():
    inside = IntervalNote(0.95, "OLS + autocovariance sandwich", 8.14, 66.0, "bench")
    beyond = IntervalNote(0.95, "OLS + autocovariance sandwich", 80.0, 66.0, "bench")
    open_window = IntervalNote(0.95, "OLS + autocovariance sandwich", 30.0, 66.0, "b", False)
    assert inside.within and inside.status == "calibrated (τ_int 8.14 ≤ 66 rows)"
    assert not beyond.within and beyond.status.startswith("BEYOND calibration (τ_int 80 > 66")
    assert not open_window.within and "τ_int ≥ 30" in open_window.status  # a lower bound only
    plain = IntervalNote(0.9, "OLS (independent errors)", 12.0)
    assert plain.within is None and plain.status == "not calibrated for correlated residuals"
    assert plain.columns() == {
        "interval": "90 % OLS (independent errors)",
        "calibration": "not calibrated for correlated residuals",
    }
    with pytest.raises(ValueError, match="level"):
        IntervalNote(95, "OLS")


def test_too_few_effective_rows_per_term_is_beyond_calibration():
    # 3,000 rows, 16 terms: at tau_int 19 that is 9.9 effectively independent rows per term;
    # at 40, 4.7 (below the benchmark's fewest, 8): beyond, whatever the correlation time says
    args = (0.95, "OLS + autocovariance sandwich")
    enough = IntervalNote(*args, 19.0, 66.0, "bench", n_rows=3000, n_terms=16,
                          calibrated_per_term=8.0)  # fmt: skip
    few = IntervalNote(*args, 40.0, 66.0, "bench", n_rows=3000, n_terms=16,
                       calibrated_per_term=8.0)  # fmt: skip
    assert enough.within and enough.status == (
        "calibrated (τ_int 19 ≤ 66 rows; 9.87 ≥ 8 effective rows per term)"
    )
    assert not few.within and few.status == (
        "BEYOND calibration (τ_int 40 rows; 4.69 < 8 effective rows per term)"
    )
    unchecked = IntervalNote(*args, 40.0, 66.0, "bench")  # no rows given: as before
    assert unchecked.per_term is None and unchecked.within
