"""The loop's decisions are typed; the report's table of them is one labelled column per field."""

import math
from dataclasses import fields, replace

import pytest

from hmid.loop import Decision
from hmid.loop.decision import ACROSS, LABELS, decision_table


def _decision(**changes):
    tested = Decision(round=1, candidate="viscous", profiled="", partial_r=0.5, f=12.0,
                      n_eff=400.0, p=1e-4, p_holm=3e-4, delta_bic=-8.0, delta_bic_common=-7.0,
                      identified=True, passes_training=True)  # fmt: skip
    return replace(tested, **changes)


def test_every_field_has_one_label_in_the_tables_order():
    assert list(LABELS) == [f.name for f in fields(Decision)]
    assert len(set(LABELS.values())) == len(LABELS)


def test_the_table_renders_each_decision_as_a_row():
    decisions = [_decision(), _decision(candidate="coulomb.x", selected=True, cv_change=-0.1)]
    table = decision_table(decisions)
    # the columns of a cross-validation across logs only where one was done
    assert list(table.columns) == [v for k, v in LABELS.items() if k not in ACROSS]
    across = decision_table([_decision(cv_across=-0.02, cv_across_upper=0.01)])
    assert list(across.columns) == list(LABELS.values())
    assert table["candidate"].tolist() == ["viscous", "coulomb.x"]
    assert table["selected"].tolist() == [False, True]
    assert math.isnan(table["CV change"].iloc[0]) and table["CV change"].iloc[1] == -0.1
    assert decision_table([]).empty


def test_a_decision_is_frozen():
    with pytest.raises(AttributeError):
        _decision().added = True
