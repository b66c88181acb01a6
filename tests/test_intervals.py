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
