"""A round's screens shared with a worker process give the numbers screened in one process."""

import pandas as pd
from _loop_data import loop_on

from hmid.loop import LoopSpec
from hmid.loop import parallel as parallel_module
from hmid.workers import WORKERS_VARIABLE


def viscous_and_drift(frame):
    return -12.0 * frame["v"] + 0.4 * frame["t"] / frame["t"].max(), {"b": 12.0, "D": 0.4}


def test_a_worker_s_screens_are_the_ones_screened_here(synthetic, monkeypatch):
    data, _ = synthetic(viscous_and_drift)
    spec = LoopSpec(base="balance")
    monkeypatch.setenv(WORKERS_VARIABLE, "0")
    alone = loop_on(data, spec)
    monkeypatch.setenv(WORKERS_VARIABLE, "1")
    ran = []
    there = parallel_module._Outcome.screen

    def noted(self, *args):
        ran.append(self)
        return there(self, *args)

    monkeypatch.setattr(parallel_module._Outcome, "screen", noted)
    shared = loop_on(data, spec)
    assert ran  # the worker screened some candidates
    assert [e.name for e in shared.effects] == [e.name for e in alone.effects]
    assert [e.name for e in alone.effects] == ["viscous", "zero_drift"]  # two rounds
    pd.testing.assert_frame_equal(shared.tests, alone.tests, check_exact=True)
    for a, b in zip(shared.effects, alone.effects, strict=True):
        pd.testing.assert_frame_equal(a.parameters, b.parameters, check_exact=True)
