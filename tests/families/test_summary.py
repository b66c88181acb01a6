"""A fit's summary is typed; metrics.json's entry keeps each family's keys in its order."""

import json

import pytest

from hmid.families.base import STATISTICS, FitSummary

STATS = dict(r2=0.9, r2_adj=0.89, rmse=0.1, aic=-3.0, bic=-2.0)


def test_the_record_orders_the_metrics_entry_and_warnings_are_a_list():
    summary = FitSummary("sls", "sls", 100, 6, **STATS, warnings=("w",),
                         record=("family", "name", "warnings", *STATISTICS))  # fmt: skip
    out = summary.to_dict()
    assert list(out) == ["family", "name", "warnings", *STATISTICS]
    assert out["warnings"] == ["w"] and summary.warnings == ("w",)
    json.dumps(out)
    assert "tau_int" not in out and summary.tau_int is None


def test_a_record_naming_no_field_is_an_error():
    with pytest.raises(ValueError, match="'tau'"):
        FitSummary("balance", "b", 100, 3, **STATS, record=("family", "tau"))
