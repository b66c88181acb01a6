"""A candidate's grid scanned coarsely, walked and filled in: the same screen as the whole grid."""

import numpy as np
import pandas as pd
from _loop_data import loop_on

import hmid.loop.screen as screen_module
from hmid.loop import LoopSpec

DELAY = 0.02  # s: between coarse values of the delay grid (every 5th of 2.5 ms steps)


def _late_pressure(frame):
    shifted = frame.groupby("segment", group_keys=False)[["t", "P"]].apply(
        lambda g: np.interp(g["t"] + DELAY, g["t"], g["P"])
    )
    return 5.0e-4 * (np.concatenate(list(shifted)) - frame["P"]), {"d": DELAY}


def test_a_coarse_scan_finds_the_whole_grids_minimum_and_interval(synthetic, monkeypatch):
    data, _ = synthetic(_late_pressure)
    spec = LoopSpec(base="balance", candidates=("delay.P", "lag.P", "stribeck"), max_effects=1)
    moved = screen_module._moved
    calls = {"coarse": 0, "whole": 0}
    runs = {}
    for mode, coarse in (("coarse", screen_module.COARSE), ("whole", 10**6)):

        def counted(*args, mode=mode):
            calls[mode] += 1
            return moved(*args)

        monkeypatch.setattr(screen_module, "COARSE", coarse)
        monkeypatch.setattr(screen_module, "_moved", counted)
        runs[mode] = loop_on(data, spec)
    coarse, whole = (runs[m].tests.set_index("candidate") for m in ("coarse", "whole"))
    assert calls["coarse"] < 0.6 * calls["whole"], calls
    assert runs["coarse"].first_named == runs["whole"].first_named == ("delay.P",)
    numbers = coarse.select_dtypes("number").columns
    pd.testing.assert_frame_equal(coarse[numbers], whole[numbers], rtol=1e-4)
    assert coarse["profiled"].equals(whole["profiled"])  # values and intervals
    delay = runs["coarse"].effects[0].parameters.set_index("parameter").loc["d"]
    assert delay["lower"] <= DELAY <= delay["upper"]
